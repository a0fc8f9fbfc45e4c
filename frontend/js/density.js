// The points as a density layer: counts binned on a screen grid, drawn into an offscreen canvas.

const CELL = 2; // device pixels per bin

export class DensityLayer {
  constructor() {
    this.canvas = document.createElement("canvas");
    this.key = "";
  }

  // Re-bins only when the view changed; `xy` is a Float32Array [x0, y0, x1, y1, ...].
  render(xy, view, width, height, rgb) {
    const key = `${view.cx},${view.cy},${view.scale},${width},${height},${xy.length}`;
    if (key === this.key) return this.canvas;
    this.key = key;
    const cols = Math.ceil(width / CELL);
    const rows = Math.ceil(height / CELL);
    const counts = binPoints(xy, view, width, height, cols, rows);
    this.canvas.width = cols;
    this.canvas.height = rows;
    const ctx = this.canvas.getContext("2d");
    ctx.putImageData(colour(counts, cols, rows, rgb), 0, 0);
    return this.canvas;
  }
}

function binPoints(xy, view, width, height, cols, rows) {
  const counts = new Uint16Array(cols * rows);
  const s = view.scale / CELL;
  const ox = width / 2 / CELL - view.cx * s;
  const oy = height / 2 / CELL + view.cy * s;
  for (let i = 0; i < xy.length; i += 2) {
    const c = (xy[i] * s + ox) | 0;
    const r = (oy - xy[i + 1] * s) | 0;
    if (c >= 0 && c < cols && r >= 0 && r < rows) {
      const k = r * cols + c;
      if (counts[k] < 65535) counts[k]++;
    }
  }
  return counts;
}

function colour(counts, cols, rows, [red, green, blue]) {
  let max = 1;
  for (let k = 0; k < counts.length; k++) if (counts[k] > max) max = counts[k];
  const norm = 1 / Math.log1p(max);
  const image = new ImageData(cols, rows);
  const px = image.data;
  for (let k = 0; k < counts.length; k++) {
    const n = counts[k];
    if (!n) continue;
    const o = k * 4;
    px[o] = red;
    px[o + 1] = green;
    px[o + 2] = blue;
    px[o + 3] = 60 + 195 * Math.log1p(n) * norm;
  }
  return image;
}
