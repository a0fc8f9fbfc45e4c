// 2D helpers in the scene's frame (units of the model, yaw in degrees CCW from +x).

const RAD = Math.PI / 180;

export const wrapDeg = (deg) => deg - 360 * Math.ceil((deg - 180) / 360);

// Frustum triangle [apex, right corner, left corner] as in core/rule/frustum.py.
export function frustum(pose) {
  const half = (pose.fov_deg * RAD) / 2;
  const side = pose.range / Math.cos(half);
  const yaw = pose.yaw_deg * RAD;
  return [
    [pose.x, pose.y],
    [pose.x + side * Math.cos(yaw - half), pose.y + side * Math.sin(yaw - half)],
    [pose.x + side * Math.cos(yaw + half), pose.y + side * Math.sin(yaw + half)],
  ];
}

function separated(a, b) {
  for (let i = 0; i < 3; i++) {
    const [x1, y1] = a[i];
    const [x2, y2] = a[(i + 1) % 3];
    const nx = y2 - y1;
    const ny = x1 - x2;
    const [minA, maxA] = project(a, nx, ny);
    const [minB, maxB] = project(b, nx, ny);
    if (maxA < minB || maxB < minA) return true;
  }
  return false;
}

function project(tri, nx, ny) {
  let min = Infinity;
  let max = -Infinity;
  for (const [x, y] of tri) {
    const d = x * nx + y * ny;
    if (d < min) min = d;
    if (d > max) max = d;
  }
  return [min, max];
}

// Separating-axis test of two triangles (touching counts as intersecting, like shapely).
export const trianglesIntersect = (a, b) => !separated(a, b) && !separated(b, a);

// Poses moved rigidly: translated by (dx, dy), then rotated by deg about their centroid.
export function rigidMove(poses, dx, dy, deg) {
  const n = poses.length;
  if (!n) return [];
  const cx = poses.reduce((s, p) => s + p.x, 0) / n;
  const cy = poses.reduce((s, p) => s + p.y, 0) / n;
  const c = Math.cos(deg * RAD);
  const s = Math.sin(deg * RAD);
  return poses.map((p) => {
    const rx = p.x - cx;
    const ry = p.y - cy;
    return {
      ...p,
      x: cx + c * rx - s * ry + dx,
      y: cy + s * rx + c * ry + dy,
      yaw_deg: wrapDeg(p.yaw_deg + deg),
    };
  });
}

// A round length (1, 2 or 5 times a power of ten) not longer than `max`.
export function niceLength(max) {
  const power = 10 ** Math.floor(Math.log10(max));
  for (const m of [5, 2, 1]) if (m * power <= max) return m * power;
  return power;
}

export const median = (values) => {
  if (!values.length) return null;
  const sorted = [...values].sort((a, b) => a - b);
  return sorted[Math.floor(sorted.length / 2)];
};

export const pairKey = (a, b) => (a < b ? `${a}-${b}` : `${b}-${a}`);
export const splitKey = (key) => key.split("-").map(Number);

// The view's extent [x0, y0, x1, y1]: the cameras' box (at least minSize wide, minSize being the
// cameras' typical range) and the central 96% of the points within a margin around it (that
// range, kept within MARGIN_SHARES of the box's size), so far stray points do not shrink the
// cameras to a corner (they stay reachable by zooming out); the points' central box when no
// camera is placed. The same rule as core/geometry.py: view_extent (used by `scene --png`).
const MARGIN_SHARES = [0.2, 0.5];
const QUANTILES = [0.02, 0.98];

export function viewExtent(cameraXY, points, minSize = 0) {
  if (!cameraXY.length) {
    if (!points.length) return null;
    const [x0, x1] = quantiles(points, 0, () => true);
    const [y0, y1] = quantiles(points, 1, () => true);
    return [x0, y0, x1, y1];
  }
  const xs = cameraXY.map((p) => p[0]);
  const ys = cameraXY.map((p) => p[1]);
  const half = Math.max(minSize, 1e-9) / 2;
  const [cx, cy] = [(Math.min(...xs) + Math.max(...xs)) / 2, (Math.min(...ys) + Math.max(...ys)) / 2];
  let [x0, y0] = [Math.min(...xs, cx - half), Math.min(...ys, cy - half)];
  let [x1, y1] = [Math.max(...xs, cx + half), Math.max(...ys, cy + half)];
  const size = Math.max(x1 - x0, y1 - y0);
  const m = Math.min(Math.max(minSize, MARGIN_SHARES[0] * size), MARGIN_SHARES[1] * size);
  const near = (i) => points[i] >= x0 - m && points[i] <= x1 + m && points[i + 1] >= y0 - m && points[i + 1] <= y1 + m;
  const [px0, px1] = quantiles(points, 0, near);
  const [py0, py1] = quantiles(points, 1, near);
  if (px0 !== undefined) [x0, x1, y0, y1] = [Math.min(x0, px0), Math.max(x1, px1), Math.min(y0, py0), Math.max(y1, py1)];
  return [x0, y0, x1, y1];
}

// The QUANTILES of coordinate `axis` of the flat [x, y, ...] points whose index passes `keep`.
function quantiles(points, axis, keep) {
  const values = [];
  for (let i = 0; i < points.length; i += 2) if (keep(i)) values.push(points[i + axis]);
  if (!values.length) return [undefined, undefined];
  const sorted = Float64Array.from(values).sort();
  const at = (q) => sorted[Math.min(sorted.length - 1, Math.floor(q * sorted.length))];
  return QUANTILES.map(at);
}
