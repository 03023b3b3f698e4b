// Rectangle clamped at a corner: omega = (-Lx/2, Lx/2) x (-Ly/2, Ly/2), clamped on the lower
// half of the left side and the left half of the bottom side, i.e. ([N15], Lx = 6, Ly = 4)
// Gamma_D = {-3} x (-2, 0)  u  (-3, 0) x {-2}.
// Facet groups: clamped (the two segments) and boundary (the rest); cell group: plate.
// quads = 1 (default): structured quadrilaterals (four transfinite blocks), quads = 0:
// unstructured triangles of size h.
// Parameters (override with dgplate: mesh.parameters = {h = 0.2}):
DefineConstant[
  Lx = {6.0, Name "Parameters/Lx"},
  Ly = {4.0, Name "Parameters/Ly"},
  h = {0.5, Name "Parameters/h"},
  quads = {1, Choices{0, 1}, Name "Parameters/quads"}
];
If (!(Lx > 0 && Ly > 0 && h > 0))
  Error("corner_clamp.geo: need Lx > 0, Ly > 0 and h > 0");
EndIf
a = Lx / 2;
b = Ly / 2;
// 7 - 8 - 9
// |   |   |
// 4 - 5 - 6
// |   |   |
// 1 - 2 - 3      clamped: 1-2 and 1-4
Point(1) = {-a, -b, 0, h};
Point(2) = {0, -b, 0, h};
Point(3) = {a, -b, 0, h};
Point(4) = {-a, 0, 0, h};
Point(5) = {0, 0, 0, h};
Point(6) = {a, 0, 0, h};
Point(7) = {-a, b, 0, h};
Point(8) = {0, b, 0, h};
Point(9) = {a, b, 0, h};
Line(1) = {1, 2};  // clamped
Line(2) = {2, 3};
Line(3) = {4, 5};
Line(4) = {5, 6};
Line(5) = {7, 8};
Line(6) = {8, 9};
Line(7) = {1, 4};  // clamped
Line(8) = {4, 7};
Line(9) = {2, 5};
Line(10) = {5, 8};
Line(11) = {3, 6};
Line(12) = {6, 9};
Curve Loop(1) = {1, 9, -3, -7};
Plane Surface(1) = {1};
Curve Loop(2) = {2, 11, -4, -9};
Plane Surface(2) = {2};
Curve Loop(3) = {3, 10, -5, -8};
Plane Surface(3) = {3};
Curve Loop(4) = {4, 12, -6, -10};
Plane Surface(4) = {4};
If (quads)
  nx = Ceil(a / h);
  ny = Ceil(b / h);
  Transfinite Curve{1, 2, 3, 4, 5, 6} = nx + 1;
  Transfinite Curve{7, 8, 9, 10, 11, 12} = ny + 1;
  Transfinite Surface{1, 2, 3, 4};
  Recombine Surface{1, 2, 3, 4};
EndIf
Physical Curve("clamped") = {1, 7};
Physical Curve("boundary") = {2, 11, 12, 6, 5, 8};
Physical Surface("plate") = {1, 2, 3, 4};
