// Rectangle [x0, x1] x [y0, y1] with a crease along a circular arc: centre (cx, cy), radius R,
// polar angles a0 to a1 (degrees). The part of the arc inside the rectangle is embedded in the
// mesh: it may run boundary to boundary or end inside (an open arc, e.g. a0 = -20, a1 = 20).
// Facet groups: left, right, bottom, top (sides) and crease (the arc C); cell group: plate.
// The two sides of C are told apart by a formula, e.g. where((x-cx)^2 + (y-cy)^2 < R^2, ..).
// Unstructured triangles of size h (h_crease along C); recombine = true in the problem file
// asks for quadrilaterals. order = 2: curved (second-order) cells with their nodes on C,
// needed for folds along a curved crease (docs/creases.md). Parameters (override with mesh.parameters = {R = 1.2, h = 0.1}):
DefineConstant[
  x0 = {-1.0, Name "Parameters/x0"},
  x1 = {1.0, Name "Parameters/x1"},
  y0 = {0.0, Name "Parameters/y0"},
  y1 = {1.0, Name "Parameters/y1"},
  cx = {-1.5, Name "Parameters/cx"},
  cy = {0.5, Name "Parameters/cy"},
  R = {1.5, Name "Parameters/R"},
  a0 = {-90.0, Name "Parameters/a0"},
  a1 = {90.0, Name "Parameters/a1"},
  h = {0.2, Name "Parameters/h"},
  h_crease = {0.0, Name "Parameters/h_crease (0: h)"},
  order = {1, Choices{1, 2}, Name "Parameters/order (2: curved cell edges along C)"}
];
If (!(x1 > x0 && y1 > y0 && R > 0 && a1 > a0 && a1 - a0 <= 360 && h > 0))
  Error("arc_crease.geo: need x1 > x0, y1 > y0, R > 0, a0 < a1 <= a0 + 360 and h > 0");
EndIf
SetFactory("OpenCASCADE");
hc = (h_crease > 0) ? h_crease : h;
Rectangle(1) = {x0, y0, 0, x1 - x0, y1 - y0};
Circle(100) = {cx, cy, 0, R, a0 * Pi / 180, a1 * Pi / 180};
arc() = BooleanIntersection{ Curve{100}; Delete; }{ Surface{1}; };
If (#arc() == 0)
  Error("arc_crease.geo: the arc does not cross the rectangle");
EndIf
BooleanFragments{ Surface{1}; Delete; }{ Curve{arc()}; Delete; }
eps = 1e-7 * (x1 - x0 + y1 - y0);
left() = Curve In BoundingBox{x0 - eps, y0 - eps, -eps, x0 + eps, y1 + eps, eps};
right() = Curve In BoundingBox{x1 - eps, y0 - eps, -eps, x1 + eps, y1 + eps, eps};
bottom() = Curve In BoundingBox{x0 - eps, y0 - eps, -eps, x1 + eps, y0 + eps, eps};
top() = Curve In BoundingBox{x0 - eps, y1 - eps, -eps, x1 + eps, y1 + eps, eps};
crease() = Curve{:};
crease() -= {left(), right(), bottom(), top()};
MeshSize{ PointsOf{ Surface{:}; } } = h;
MeshSize{ PointsOf{ Curve{crease()}; } } = hc;
Mesh.MeshSizeMax = Max(h, hc);
Mesh.ElementOrder = order;
Physical Curve("left") = {left()};
Physical Curve("right") = {right()};
Physical Curve("bottom") = {bottom()};
Physical Curve("top") = {top()};
Physical Curve("crease") = {crease()};
Physical Surface("plate") = {Surface{:}};
