// Laying a capture-order stretch of cameras along a drawn path, in the scene's 2D frame: a
// polyline (first camera at its first vertex) or a circle for an orbit. Spacing is the stretch's
// own step (the mean distance between consecutive cameras: a run's relative placement is usually
// right, while the end of a hand-drawn path is not), evenly over the path instead when the stretch
// at its own step would not fit on it (nothing is laid past what was drawn). Yaw looks along the
// path or to its centre (the circle's centre; a polyline's vertex centroid).
import { wrapDeg } from "./geometry.js";

const DEG = 180 / Math.PI;

// The mean distance between consecutive points [[x, y], ...]; null for fewer than two.
export function meanStep(points) {
  if (points.length < 2) return null;
  let sum = 0;
  for (let i = 1; i < points.length; i++) sum += distance(points[i - 1], points[i]);
  return sum / (points.length - 1) || null;
}

export function pathLength(vertices) {
  let sum = 0;
  for (let i = 1; i < vertices.length; i++) sum += distance(vertices[i - 1], vertices[i]);
  return sum;
}

// The spacing of `gaps` gaps on a path of `length`: the step when they fit, else even.
export function spacing(step, length, gaps) {
  if (gaps <= 0) return 0;
  return step && step * gaps <= length ? step : length / gaps;
}

// n poses {x, y, yaw_deg} along the polyline; yawMode "along" | "centre".
export function alongPolyline(vertices, n, step, yawMode) {
  const gap = spacing(step, pathLength(vertices), n - 1);
  const centre = centroid(vertices);
  return Array.from({ length: n }, (_, i) => {
    const p = pointAt(vertices, i * gap);
    return { x: p.x, y: p.y, yaw_deg: yawMode === "centre" ? bearing(p, centre) : p.heading };
  });
}

// n poses around the circle from the bearing startDeg, turning counter-clockwise (direction 1) or
// clockwise (-1); a closed path, so n cameras have n gaps.
export function alongCircle({ centre, radius, startDeg, direction }, n, step, yawMode) {
  const turn = (spacing(step, 2 * Math.PI * radius, n) / radius) * direction;
  return Array.from({ length: n }, (_, i) => {
    const theta = startDeg / DEG + i * turn;
    const p = { x: centre[0] + radius * Math.cos(theta), y: centre[1] + radius * Math.sin(theta) };
    const yaw = yawMode === "centre" ? theta * DEG + 180 : theta * DEG + 90 * direction;
    return { ...p, yaw_deg: wrapDeg(yaw) };
  });
}

// Which way a stretch turns: the sign of its summed heading changes (1 counter-clockwise, the
// default when it does not turn, -1 clockwise); an orbit turns the way it travels.
export function turnDirection(yaws) {
  let sum = 0;
  for (let i = 1; i < yaws.length; i++) sum += wrapDeg(yaws[i] - yaws[i - 1]);
  return sum < 0 ? -1 : 1;
}

// The point and heading (deg) at arc length s along the polyline (its last point beyond the end).
function pointAt(vertices, s) {
  let left = s;
  for (let i = 1; i < vertices.length; i++) {
    const [a, b] = [vertices[i - 1], vertices[i]];
    const length = distance(a, b);
    if (left <= length || i === vertices.length - 1) {
      const f = length > 0 ? Math.min(left / length, 1) : 0;
      return { x: a[0] + f * (b[0] - a[0]), y: a[1] + f * (b[1] - a[1]),
        heading: Math.atan2(b[1] - a[1], b[0] - a[0]) * DEG };
    }
    left -= length;
  }
  return { x: vertices[0][0], y: vertices[0][1], heading: 0 };
}

const distance = (a, b) => Math.hypot(b[0] - a[0], b[1] - a[1]);
const bearing = (p, centre) => Math.atan2(centre[1] - p.y, centre[0] - p.x) * DEG;

function centroid(points) {
  const n = points.length;
  return [points.reduce((s, p) => s + p[0], 0) / n, points.reduce((s, p) => s + p[1], 0) / n];
}
