// Rectangle [0, Lx] x [0, Ly], unstructured, with named sides.
// Parameters (override with dgplate: mesh.parameters = {Lx = 2, h = 0.1}):
DefineConstant[
  Lx = {4.0, Name "Parameters/Lx"},
  Ly = {4.0, Name "Parameters/Ly"},
  h = {0.5, Name "Parameters/h"},
  quads = {0, Choices{0, 1}, Name "Parameters/quads"}
];
Point(1) = {0, 0, 0, h};
Point(2) = {Lx, 0, 0, h};
Point(3) = {Lx, Ly, 0, h};
Point(4) = {0, Ly, 0, h};
Line(1) = {1, 2};
Line(2) = {2, 3};
Line(3) = {3, 4};
Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
If (quads)
  Recombine Surface{1};
EndIf
Physical Curve("bottom") = {1};
Physical Curve("right") = {2};
Physical Curve("top") = {3};
Physical Curve("left") = {4};
Physical Surface("plate") = {1};
