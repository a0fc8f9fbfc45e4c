// Drawing primitives of the scene, batched into one path per colour. `t` maps world to device
// pixels: t(x, y) -> [sx, sy]; `px` is the device pixels per CSS pixel.
import { frustum, niceLength } from "./geometry.js";

const RAD = Math.PI / 180;

// Cameras as a dot with a heading stroke; items are [camera, pose] pairs.
export function drawGlyphs(ctx, t, items, { radius, length, colour, px }) {
  ctx.beginPath();
  for (const [, p] of items) {
    const [sx, sy] = t(p.x, p.y);
    ctx.moveTo(sx + radius, sy);
    ctx.arc(sx, sy, radius, 0, 2 * Math.PI);
  }
  ctx.fillStyle = colour;
  ctx.fill();
  ctx.beginPath();
  for (const [, p] of items) {
    const [sx, sy] = t(p.x, p.y);
    const yaw = p.yaw_deg * RAD;
    ctx.moveTo(sx, sy);
    ctx.lineTo(sx + length * Math.cos(yaw), sy - length * Math.sin(yaw));
  }
  ctx.lineWidth = 2 * px;
  ctx.strokeStyle = colour;
  ctx.stroke();
}

export function drawFrusta(ctx, t, items, { fill, stroke, px }) {
  ctx.beginPath();
  for (const [, pose] of items) {
    if (!pose.fov_deg || !pose.range) continue;
    const [a, b, c] = frustum(pose).map(([x, y]) => t(x, y));
    ctx.moveTo(a[0], a[1]);
    ctx.lineTo(b[0], b[1]);
    ctx.lineTo(c[0], c[1]);
    ctx.closePath();
  }
  ctx.fillStyle = fill;
  ctx.fill();
  ctx.lineWidth = px;
  ctx.strokeStyle = stroke;
  ctx.stroke();
}

// Segments [[x1, y1, x2, y2], ...] in world units, one stroke.
export function drawSegments(ctx, t, segments, { colour, width, dash = [] }) {
  if (!segments.length) return;
  ctx.beginPath();
  for (const [x1, y1, x2, y2] of segments) {
    const [ax, ay] = t(x1, y1);
    const [bx, by] = t(x2, y2);
    ctx.moveTo(ax, ay);
    ctx.lineTo(bx, by);
  }
  ctx.setLineDash(dash);
  ctx.lineWidth = width;
  ctx.strokeStyle = colour;
  ctx.stroke();
  ctx.setLineDash([]);
}

export function drawArrows(ctx, t, arrows, { colour, px }) {
  if (!arrows.length) return;
  ctx.beginPath();
  const head = 7 * px;
  for (const { from, to } of arrows) {
    const [ax, ay] = t(from[0], from[1]);
    const [bx, by] = t(to[0], to[1]);
    const angle = Math.atan2(by - ay, bx - ax);
    ctx.moveTo(ax, ay);
    ctx.lineTo(bx, by);
    ctx.lineTo(bx - head * Math.cos(angle - 0.4), by - head * Math.sin(angle - 0.4));
    ctx.moveTo(bx, by);
    ctx.lineTo(bx - head * Math.cos(angle + 0.4), by - head * Math.sin(angle + 0.4));
  }
  ctx.lineWidth = 1.5 * px;
  ctx.strokeStyle = colour;
  ctx.stroke();
}

// A round length bar in the bottom-left corner, in metres once the user set a known distance
// (metresPerUnit), else in the model's units; returns [its length in world units, its label].
export function drawScaleBar(ctx, { width, height, scale, px, ink, background, metresPerUnit = null }) {
  const perUnit = metresPerUnit ?? 1;
  const shown = niceLength((width * 0.2 * perUnit) / scale);
  const length = shown / perUnit;
  const bar = length * scale;
  const x = 14 * px;
  const y = height - 14 * px;
  ctx.fillStyle = background;
  ctx.fillRect(x - 6 * px, y - 22 * px, bar + 12 * px, 30 * px);
  ctx.strokeStyle = ink;
  ctx.lineWidth = 2 * px;
  ctx.beginPath();
  ctx.moveTo(x, y - 5 * px);
  ctx.lineTo(x, y);
  ctx.lineTo(x + bar, y);
  ctx.lineTo(x + bar, y - 5 * px);
  ctx.stroke();
  ctx.fillStyle = ink;
  ctx.font = `${12 * px}px system-ui, sans-serif`;
  const value = +shown.toPrecision(3);
  const label = metresPerUnit ? `${value} m` : `${value} ${value === 1 ? "unit" : "units"}`;
  ctx.fillText(label, x, y - 8 * px);
  return [length, label];
}

// Small text labels [[text, pose], ...] beside their cameras, skipping any that would overlap
// one already drawn; returns the drawn ones as [text, sx, sy] (device pixels).
export function drawLabels(ctx, t, items, { colour, halo, px }) {
  const drawn = [];
  const gap = 14 * px;
  ctx.font = `${10 * px}px system-ui, sans-serif`;
  ctx.lineWidth = 3 * px;
  ctx.strokeStyle = halo;
  ctx.fillStyle = colour;
  for (const [text, p] of items) {
    const [sx, sy] = t(p.x, p.y);
    const [lx, ly] = [sx + 5 * px, sy - 5 * px];
    if (drawn.some(([, x, y]) => Math.abs(x - lx) < gap && Math.abs(y - ly) < gap)) continue;
    ctx.strokeText(text, lx, ly);
    ctx.fillText(text, lx, ly);
    drawn.push([text, Math.round(lx), Math.round(ly)]);
  }
  return drawn;
}
