// Drawing the triage tools on the scene (same conventions as glyphs.js: `t` maps world to device
// pixels, `px` is device pixels per CSS pixel): proposed poses as ghost cameras joined to where
// their cameras are now, the rings of split-off models, and the path being drawn.
import { drawSegments } from "./glyphs.js";

const RAD = Math.PI / 180;

// Ghost cameras, each joined by a dashed line to its camera's pose now (nowOf(id), or null).
export function drawProposals(ctx, t, ghosts, nowOf, { colour, px }) {
  const segments = [];
  for (const g of ghosts) {
    const now = nowOf(g.id);
    if (now) segments.push([now.x, now.y, g.x, g.y]);
  }
  drawSegments(ctx, t, segments, { colour, width: px, dash: [2 * px, 3 * px] });
  drawGhostCameras(ctx, t, ghosts, { colour, px });
}

// The poses of each split-off model's cameras (model index -> poses), from [camera, pose] items.
export function groupsOf(posed) {
  const groups = new Map();
  for (const [cam, pose] of posed) {
    if (!cam.group) continue;
    if (!groups.has(cam.model)) groups.set(cam.model, []);
    groups.get(cam.model).push(pose);
  }
  return groups;
}

// Proposed poses as hollow cameras with a dashed heading; a hot one (its run hovered) is larger.
export function drawGhostCameras(ctx, t, ghosts, { colour, px }) {
  ctx.setLineDash([3 * px, 2 * px]);
  ctx.strokeStyle = colour;
  for (const g of ghosts) {
    const [sx, sy] = t(g.x, g.y);
    const [radius, length] = g.hot ? [6 * px, 18 * px] : [4 * px, 13 * px];
    const yaw = g.yaw_deg * RAD;
    ctx.lineWidth = (g.hot ? 2.5 : 1.5) * px;
    ctx.beginPath();
    ctx.moveTo(sx + radius, sy);
    ctx.arc(sx, sy, radius, 0, 2 * Math.PI);
    ctx.moveTo(sx + radius * Math.cos(yaw), sy - radius * Math.sin(yaw));
    ctx.lineTo(sx + length * Math.cos(yaw), sy - length * Math.sin(yaw));
    ctx.stroke();
  }
  ctx.setLineDash([]);
}

// The path being drawn: a polyline (with a rubber band to the cursor) or a circle and its radius.
export function drawSketch(ctx, t, sketch, { colour, px }) {
  ctx.beginPath();
  if (sketch.kind === "circle" && sketch.centre) {
    const [cx, cy] = t(...sketch.centre);
    const [ex, ey] = t(sketch.centre[0] + sketch.radius, sketch.centre[1]);
    ctx.arc(cx, cy, Math.abs(ex - cx), 0, 2 * Math.PI);
    if (sketch.start) {
      ctx.moveTo(cx, cy);
      ctx.lineTo(...t(...sketch.start));
    }
  } else if (sketch.kind === "polyline") {
    const points = sketch.cursor ? [...sketch.points, sketch.cursor] : sketch.points;
    points.forEach(([x, y], i) => (i ? ctx.lineTo(...t(x, y)) : ctx.moveTo(...t(x, y))));
  }
  ctx.setLineDash([6 * px, 4 * px]);
  ctx.lineWidth = 2 * px;
  ctx.strokeStyle = colour;
  ctx.stroke();
  ctx.setLineDash([]);
}

// A dashed circle around each split-off model's cameras, so the group reads as one piece.
export function drawGroupOutlines(ctx, t, groups, { colour, px }) {
  ctx.beginPath();
  for (const poses of groups.values()) {
    const cx = poses.reduce((s, p) => s + p.x, 0) / poses.length;
    const cy = poses.reduce((s, p) => s + p.y, 0) / poses.length;
    const reach = Math.max(...poses.map((p) => Math.hypot(p.x - cx, p.y - cy)));
    const [sx, sy] = t(cx, cy);
    const [ex] = t(cx + reach, cy);
    const radius = ex - sx + 12 * px;
    ctx.moveTo(sx + radius, sy);
    ctx.arc(sx, sy, radius, 0, 2 * Math.PI);
  }
  ctx.setLineDash([2 * px, 4 * px]);
  ctx.lineWidth = 1.5 * px;
  ctx.strokeStyle = colour;
  ctx.stroke();
  ctx.setLineDash([]);
}
