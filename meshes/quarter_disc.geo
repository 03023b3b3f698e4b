// The quarter |x| < R, x > 0, y > 0 of a disc: structured quadrilaterals (an O-grid), mirror
// symmetric about the diagonal y = x (to round-off), so a mode that breaks the disc's symmetry
// between x and y is not favoured by the mesh (docs/path_following.md, the heated disc).
// A square core [0, s]² (s = 0.45 R) of n × n cells and two patches of n × n cells between
// it and the arc; the rim is the polygon of the arc's nodes.
// Facet groups: x_axis (y = 0), y_axis (x = 0), rim (|x| = R); cell group: plate.
DefineConstant[
  R = {1.0, Name "Parameters/R"},
  n = {4, Name "Parameters/n (cells along each side of the core)"}
];
If (!(R > 0 && n >= 1))
  Error("quarter_disc.geo: need R > 0 and n >= 1");
EndIf
s = 0.45 * R;
Point(1) = {0, 0, 0};
Point(2) = {s, 0, 0};
Point(3) = {R, 0, 0};
Point(4) = {s, s, 0};
Point(5) = {R * Cos(Pi / 4), R * Sin(Pi / 4), 0};
Point(6) = {0, s, 0};
Point(7) = {0, R, 0};
Line(1) = {1, 2};
Line(2) = {2, 3};
Line(3) = {2, 4};
Line(4) = {4, 6};
Line(5) = {6, 1};
Line(6) = {7, 6};
Circle(7) = {3, 1, 5};
Circle(8) = {5, 1, 7};
Line(9) = {4, 5};
Transfinite Curve{1:9} = n + 1;
Curve Loop(1) = {1, 3, 4, 5};
Curve Loop(2) = {2, 7, -9, -3};
Curve Loop(3) = {9, 8, 6, -4};
For k In {1:3}
  Plane Surface(k) = {k};
  Transfinite Surface{k};
  Recombine Surface{k};
EndFor
Physical Curve("x_axis") = {1, 2};
Physical Curve("y_axis") = {5, 6};
Physical Curve("rim") = {7, 8};
Physical Surface("plate") = {1, 2, 3};
