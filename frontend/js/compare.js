// A 2D similarity (scale, rotation, translation) fitted by least squares to point pairs [from, to].

export function fitSimilarity(pairs) {
  if (!pairs.length) return (p) => p;
  const n = pairs.length;
  let [fx, fy, tx, ty] = [0, 0, 0, 0];
  for (const [[ax, ay], [bx, by]] of pairs) { fx += ax; fy += ay; tx += bx; ty += by; }
  [fx, fy, tx, ty] = [fx / n, fy / n, tx / n, ty / n];
  let [a, b, norm] = [0, 0, 0];
  for (const [[ax, ay], [bx, by]] of pairs) {
    const [px, py, qx, qy] = [ax - fx, ay - fy, bx - tx, by - ty];
    a += px * qx + py * qy;
    b += px * qy - py * qx;
    norm += px * px + py * py;
  }
  // With one pair (or coincident points) keep scale and rotation, translate only.
  const [c, s] = norm > 1e-12 ? [a / norm, b / norm] : [1, 0];
  return ([x, y]) => [tx + c * (x - fx) - s * (y - fy), ty + s * (x - fx) + c * (y - fy)];
}
