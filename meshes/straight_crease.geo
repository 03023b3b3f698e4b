// Rectangle [x0, x1] x [0, Ly] with a straight crease from (xb, 0) to (xt, Ly).
// Facet groups: left, right, bottom, top (sides) and crease (the interior line C);
// cell groups: side_left and side_right (the two sides of C; gmsh tags each cell once).
// quads = 1: structured quadrilaterals (transfinite); structured = 1: structured triangles
// (the same grid, each square cut by a diagonal); else unstructured triangles of size h.
// Parameters (override with dgplate: mesh.parameters = {xb = 0.2, h = 0.1}):
DefineConstant[
  x0 = {-1.0, Name "Parameters/x0"},
  x1 = {1.0, Name "Parameters/x1"},
  Ly = {1.0, Name "Parameters/Ly"},
  xb = {0.0, Name "Parameters/xb"},
  xt = {0.0, Name "Parameters/xt"},
  h = {0.25, Name "Parameters/h"},
  quads = {0, Choices{0, 1}, Name "Parameters/quads"},
  structured = {0, Choices{0, 1}, Name "Parameters/structured"}
];
If (!(x0 < xb && xb < x1 && x0 < xt && xt < x1 && Ly > 0 && h > 0))
  Error("straight_crease.geo: need x0 < xb, xt < x1, Ly > 0 and h > 0");
EndIf
Point(1) = {x0, 0, 0, h};
Point(2) = {xb, 0, 0, h};
Point(3) = {x1, 0, 0, h};
Point(4) = {x1, Ly, 0, h};
Point(5) = {xt, Ly, 0, h};
Point(6) = {x0, Ly, 0, h};
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
If (quads || structured)
  nl = Ceil(Max(xb - x0, xt - x0) / h);
  nr = Ceil(Max(x1 - xb, x1 - xt) / h);
  ny = Ceil(Ly / h);
  Transfinite Curve{1, 5} = nl + 1;
  Transfinite Curve{2, 4} = nr + 1;
  Transfinite Curve{3, 6, 7} = ny + 1;
  Transfinite Surface{1};
  Transfinite Surface{2};
  If (quads)
    Recombine Surface{1, 2};
  EndIf
EndIf
Physical Curve("bottom") = {1, 2};
Physical Curve("right") = {3};
Physical Curve("top") = {4, 5};
Physical Curve("left") = {6};
Physical Curve("crease") = {7};
Physical Surface("side_left") = {1};
Physical Surface("side_right") = {2};
