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
