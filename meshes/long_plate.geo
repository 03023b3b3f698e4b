// Partially clamped long plate: omega = (-W/2, W/2) x (0, L), clamped only on the middle part
// (-c/2, c/2) x {0} of the bottom side ([N15]: W = 4, L = 10, c = 2).
// Facet groups: clamped (the middle of the bottom side) and boundary (every other side);
// cell group: plate. quads = 1 (default): structured quadrilaterals (three transfinite strips),
// quads = 0: unstructured triangles of size h.
// Parameters (override with dgplate: mesh.parameters = {h = 0.2, L = 6}):
DefineConstant[
  W = {4.0, Name "Parameters/W"},
  L = {10.0, Name "Parameters/L"},
  c = {2.0, Name "Parameters/c"},
  h = {0.5, Name "Parameters/h"},
  quads = {1, Choices{0, 1}, Name "Parameters/quads"}
];
If (!(W > 0 && L > 0 && c > 0 && c < W && h > 0))
  Error("long_plate.geo: need W > 0, L > 0, 0 < c < W and h > 0");
EndIf
a = W / 2;
b = c / 2;
Point(1) = {-a, 0, 0, h};
Point(2) = {-b, 0, 0, h};
Point(3) = {b, 0, 0, h};
Point(4) = {a, 0, 0, h};
Point(5) = {a, L, 0, h};
Point(6) = {b, L, 0, h};
Point(7) = {-b, L, 0, h};
Point(8) = {-a, L, 0, h};
Line(1) = {1, 2};
Line(2) = {2, 3};
Line(3) = {3, 4};
Line(4) = {4, 5};
Line(5) = {5, 6};
Line(6) = {6, 7};
Line(7) = {7, 8};
Line(8) = {8, 1};
Line(9) = {2, 7};
Line(10) = {3, 6};
Curve Loop(1) = {1, 9, 7, 8};
Plane Surface(1) = {1};
Curve Loop(2) = {2, 10, 6, -9};
Plane Surface(2) = {2};
Curve Loop(3) = {3, 4, 5, -10};
Plane Surface(3) = {3};
If (quads)
  ns = Ceil((a - b) / h);
  nc = Ceil(c / h);
  ny = Ceil(L / h);
  Transfinite Curve{1, 7, 3, 5} = ns + 1;
  Transfinite Curve{2, 6} = nc + 1;
  Transfinite Curve{4, 8, 9, 10} = ny + 1;
  Transfinite Surface{1, 2, 3};
  Recombine Surface{1, 2, 3};
EndIf
Physical Curve("clamped") = {2};
Physical Curve("boundary") = {1, 3, 4, 5, 6, 7, 8};
Physical Surface("plate") = {1, 2, 3};
