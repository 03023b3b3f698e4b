// Rectangle [0, Lx] x [0, Ly] with a circular hole of radius R centred at (cx, cy) (default:
// the centre of the plate). [N15]: aspect ratio Lx/Ly = 10/4, clamped on the short side x = 0.
// Facet groups: clamped (the side x = 0), boundary (the other three sides) and hole;
// cell group: plate. quads = 1 (default): unstructured quadrilaterals (gmsh's frontal-Delaunay
// for quads + recombination), quads = 0: triangles. h is the target size, hole_h the size on
// the hole (default h / 2).
// Parameters (override with dgplate: mesh.parameters = {h = 0.2, R = 0.5}):
DefineConstant[
  Lx = {10.0, Name "Parameters/Lx"},
  Ly = {4.0, Name "Parameters/Ly"},
  R = {1.0, Name "Parameters/R"},
  cx = {Lx / 2, Name "Parameters/cx"},
  cy = {Ly / 2, Name "Parameters/cy"},
  h = {0.25, Name "Parameters/h"},
  hole_h = {h / 2, Name "Parameters/hole_h"},
  quads = {1, Choices{0, 1}, Name "Parameters/quads"}
];
If (!(R > 0 && cx - R > 0 && cx + R < Lx && cy - R > 0 && cy + R < Ly && h > 0 && hole_h > 0))
  Error("plate_with_hole.geo: the hole (R, cx, cy) must lie inside the plate, h > 0");
EndIf
Point(1) = {0, 0, 0, h};
Point(2) = {Lx, 0, 0, h};
Point(3) = {Lx, Ly, 0, h};
Point(4) = {0, Ly, 0, h};
Line(1) = {1, 2};
Line(2) = {2, 3};
Line(3) = {3, 4};
Line(4) = {4, 1};
Point(5) = {cx, cy, 0, hole_h};
Point(6) = {cx + R, cy, 0, hole_h};
Point(7) = {cx, cy + R, 0, hole_h};
Point(8) = {cx - R, cy, 0, hole_h};
Point(9) = {cx, cy - R, 0, hole_h};
Circle(5) = {6, 5, 7};
Circle(6) = {7, 5, 8};
Circle(7) = {8, 5, 9};
Circle(8) = {9, 5, 6};
Curve Loop(1) = {1, 2, 3, 4};
Curve Loop(2) = {5, 6, 7, 8};
Plane Surface(1) = {1, 2};
If (quads)
  Mesh.Algorithm = 8;  // frontal-Delaunay for quads
  Mesh.RecombinationAlgorithm = 3;  // blossom full-quad: no triangles left
  Recombine Surface{1};
EndIf
Physical Curve("clamped") = {4};
Physical Curve("boundary") = {1, 2, 3};
Physical Curve("hole") = {5, 6, 7, 8};
Physical Surface("plate") = {1};
