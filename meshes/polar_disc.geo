// Disc |x| < R of N identical sectors: a triangle mesh with exact N-fold rotational symmetry
// (every node, edge and cell rotated by 2π/N is one again, to round-off), for bifurcations
// out of an axisymmetric state (docs/fvk_experiments.md).
// Rings of nodes at radii r_k: K_in rings spaced evenly up to Rc (0 < Rc < R), K_out rings
// spaced evenly from Rc to R, K_in = ceil(Rc/h), K_out = ceil((R − Rc)/h). Ring k has m_k nodes
// per sector, m_k = max(m_{k−1}, round(2π r_k/(N Δ_k)), 1) (Δ_k the radial spacing there), so the
// cells are about h wide; the centre is one node, surrounded by N triangles. Between two rings
// each sector is triangulated by the same zipper (the next triangle takes the nearer of the
// two next nodes by angle within the sector), so all sectors are meshed alike. Each triangle is
// one geometric surface meshed as one cell.
// Facet groups: outer (|x| = R, the polygon of the outer ring); cell groups: inner_ring (the
// cells inside the ring r = Rc) and outer_ring (the others). Parameters:
DefineConstant[
  R = {1.0, Name "Parameters/R"},
  Rc = {0.15, Name "Parameters/Rc"},
  N = {16, Name "Parameters/N (sectors)"},
  h = {0.15, Name "Parameters/h"}
];
If (!(Rc > 0 && Rc < R && N >= 3 && h > 0))
  Error("polar_disc.geo: need 0 < Rc < R, N >= 3 and h > 0");
EndIf
K_in = Ceil(Rc / h);
K_out = Ceil((R - Rc) / h);
K = K_in + K_out;
lc = 10 * R;  // larger than every cell: no nodes but the points
Point(1) = {0, 0, 0, lc};
m[0] = 0;
first[0] = 1;
next = 2;
For k In {1:K}
  If (k <= K_in)
    r[k] = Rc * k / K_in;
    dr = Rc / K_in;
  Else
    r[k] = Rc + (R - Rc) * (k - K_in) / K_out;
    dr = (R - Rc) / K_out;
  EndIf
  m[k] = Floor(2 * Pi * r[k] / (N * dr) + 0.5);
  If (m[k] < m[k - 1])
    m[k] = m[k - 1];
  EndIf
  If (m[k] < 1)
    m[k] = 1;
  EndIf
  first[k] = next;
  For s In {0:N - 1}
    For j In {0:m[k] - 1}
      t = 2 * Pi * (s + j / m[k]) / N;
      Point(next) = {r[k] * Cos(t), r[k] * Sin(t), 0, lc};
      next += 1;
    EndFor
  EndFor
EndFor

inside() = {};
outside() = {};
rim() = {};
For k In {1:K}
  a = m[k - 1];
  b = m[k];
  For s In {0:N - 1}
    i = 0;
    j = 0;
    For step In {1:a + b}
      // advance on the inner ring when its next node comes first (the centre: never)
      inner = 0;
      If (a > 0 && i < a)
        inner = (j >= b || (i + 1) / a < (j + 1) / Max(b, 1));
      EndIf
      // the triangle: two consecutive nodes of one ring and one of the other, counter-clockwise
      // (node j = m_k of a sector is node 0 of the next; ring 0 is the centre, point 1)
      If (inner)
        p1 = first[k - 1] + ((s * a + i + 1) % (N * Max(a, 1)));
        p2 = first[k - 1] + ((s * a + i) % (N * Max(a, 1)));
        p3 = first[k] + ((s * b + j) % (N * b));
        i += 1;
      Else
        p1 = first[k] + ((s * b + j) % (N * b));
        p2 = first[k] + ((s * b + j + 1) % (N * b));
        p3 = (a > 0) ? first[k - 1] + ((s * a + i) % (N * Max(a, 1))) : 1;
        j += 1;
      EndIf
      l1 = newl; Line(l1) = {p1, p2};
      l2 = newl; Line(l2) = {p2, p3};
      l3 = newl; Line(l3) = {p3, p1};
      Transfinite Curve{l1, l2, l3} = 2;
      c = newcl; Curve Loop(c) = {l1, l2, l3};
      f = news; Plane Surface(f) = {c};
      Transfinite Surface{f};
      If (k == K && !inner)
        rim() += {l1};
      EndIf
      If (k <= K_in)
        inside() += {f};
      Else
        outside() += {f};
      EndIf
    EndFor
  EndFor
EndFor
Physical Curve("outer") = {rim()};
Physical Surface("inner_ring") = {inside()};
Physical Surface("outer_ring") = {outside()};
