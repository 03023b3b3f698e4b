// Annulus R_in < |x| < R_out (a disc when R_in = 0) centred at the origin, with a crease along
// the circle |x| = Rc (R_in < Rc < R_out).
// Facet groups: outer (|x| = R_out), inner (|x| = R_in, annulus only), crease (the circle C);
// cell groups: inner_ring (|x| < Rc) and outer_ring (|x| > Rc).
// Unstructured triangles of size h (h_crease along C); recombine = true in the problem file
// asks for quadrilaterals. order = 2: curved (second-order) cells with their nodes on C,
// needed for folds along a curved crease (docs/creases.md). Parameters (override with mesh.parameters = {Rc = 0.75, h = 0.05}):
DefineConstant[
  R_in = {0.5, Name "Parameters/R_in (0: a disc)"},
  R_out = {1.5, Name "Parameters/R_out"},
  Rc = {1.0, Name "Parameters/Rc"},
  h = {0.15, Name "Parameters/h"},
  h_crease = {0.0, Name "Parameters/h_crease (0: h)"},
  order = {1, Choices{1, 2}, Name "Parameters/order (2: curved cell edges along C)"}
];
If (!(R_in >= 0 && R_in < Rc && Rc < R_out && h > 0))
  Error("annulus_crease.geo: need 0 <= R_in < Rc < R_out and h > 0");
EndIf
SetFactory("OpenCASCADE");
hc = (h_crease > 0) ? h_crease : h;
Disk(1) = {0, 0, 0, R_out};
If (R_in > 0)
  Disk(2) = {0, 0, 0, R_in};
  BooleanDifference{ Surface{1}; Delete; }{ Surface{2}; Delete; }
EndIf
Circle(100) = {0, 0, 0, Rc};
BooleanFragments{ Surface{:}; Delete; }{ Curve{100}; Delete; }
eps = 1e-7 * R_out;
inner() = {};
If (R_in > 0)
  inner() = Curve In BoundingBox{-R_in - eps, -R_in - eps, -eps, R_in + eps, R_in + eps, eps};
EndIf
crease() = Curve In BoundingBox{-Rc - eps, -Rc - eps, -eps, Rc + eps, Rc + eps, eps};
crease() -= {inner()};
outer() = Curve{:};
outer() -= {inner(), crease()};
inside() = Surface In BoundingBox{-Rc - eps, -Rc - eps, -eps, Rc + eps, Rc + eps, eps};
outside() = Surface{:};
outside() -= {inside()};
MeshSize{ PointsOf{ Surface{:}; } } = h;
MeshSize{ PointsOf{ Curve{crease()}; } } = hc;
Mesh.MeshSizeMax = Max(h, hc);
Mesh.MeshSizeFromCurvature = 0;
Mesh.ElementOrder = order;
Physical Curve("outer") = {outer()};
If (R_in > 0)
  Physical Curve("inner") = {inner()};
EndIf
Physical Curve("crease") = {crease()};
Physical Surface("inner_ring") = {inside()};
Physical Surface("outer_ring") = {outside()};
