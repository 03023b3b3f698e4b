// Rectangle [0, Lx] x [0, Ly] with a straight crease x = xc from bottom to top.
// Facet groups: left, right, bottom, top (sides), crease (interior line); cell group: plate.
// quads = 1: structured quadrilaterals (transfinite), else unstructured triangles.
// Parameters (override with dgplate: mesh.parameters = {xc = 0.5, h = 0.05}):
DefineConstant[
  Lx = {2.0, Name "Parameters/Lx"},
  Ly = {1.0, Name "Parameters/Ly"},
  xc = {1.0, Name "Parameters/xc"},
  h = {0.1, Name "Parameters/h"},
  quads = {0, Choices{0, 1}, Name "Parameters/quads"}
];
Point(1) = {0, 0, 0, h};
Point(2) = {xc, 0, 0, h};
Point(3) = {Lx, 0, 0, h};
Point(4) = {Lx, Ly, 0, h};
Point(5) = {xc, Ly, 0, h};
Point(6) = {0, Ly, 0, h};
Line(1) = {1, 2};
Line(2) = {2, 3};
Line(3) = {3, 4};
Line(4) = {4, 5};
Line(5) = {5, 6};
Line(6) = {6, 1};
Line(7) = {2, 5};
Curve Loop(1) = {1, 7, 5, 6};
Plane Surface(1) = {1};
Curve Loop(2) = {2, 3, 4, -7};
Plane Surface(2) = {2};
If (quads)
  // structured quadrilaterals of size about h
  nx1 = Ceil(xc / h);
  nx2 = Ceil((Lx - xc) / h);
  ny = Ceil(Ly / h);
  Transfinite Curve{1, 5} = nx1 + 1;
  Transfinite Curve{2, 4} = nx2 + 1;
  Transfinite Curve{3, 6, 7} = ny + 1;
  Transfinite Surface{1};
  Transfinite Surface{2};
  Recombine Surface{1, 2};
EndIf
Physical Curve("bottom") = {1, 2};
Physical Curve("right") = {3};
Physical Curve("top") = {4, 5};
Physical Curve("left") = {6};
Physical Curve("crease") = {7};
Physical Surface("plate") = {1, 2};
