// Self-folding microcapsule ([N15], "Encapsulation with Self-Folding Microcapsules"):
// a centre unit square with four trapezoidal flaps, base 1 (the square's side), top 3/5,
// height 1. Structured mesh, n cells along every side (quads = 1: quadrilaterals).
//
//            +---+          flap_north: (0,1) (1,1) (0.8,2) (0.2,2)
//           /     \
//      +-- +-------+ --+
//      |   | centre|   |    centre = [0,1]²
//      +-- +-------+ --+
//           \     /
//            +---+          flap_south
//
// Cell groups: centre, flap_north, flap_south, flap_east, flap_west.
// Facet group: tips (the flaps' free short edges).
DefineConstant[
  top = {0.6, Name "Parameters/top"},
  height = {1.0, Name "Parameters/height"},
  n = {8, Name "Parameters/n"},
  quads = {1, Choices{0, 1}, Name "Parameters/quads"}
];
a = (1 - top) / 2;  // inset of the flap's top on each side

Point(1) = {0, 0, 0};
Point(2) = {1, 0, 0};
Point(3) = {1, 1, 0};
Point(4) = {0, 1, 0};
Point(5) = {a, -height, 0};      // south flap top
Point(6) = {1 - a, -height, 0};
Point(7) = {1 + height, a, 0};   // east flap top
Point(8) = {1 + height, 1 - a, 0};
Point(9) = {1 - a, 1 + height, 0};  // north flap top
Point(10) = {a, 1 + height, 0};
Point(11) = {-height, 1 - a, 0};  // west flap top
Point(12) = {-height, a, 0};

// centre square
Line(1) = {1, 2};
Line(2) = {2, 3};
Line(3) = {3, 4};
Line(4) = {4, 1};
// south flap
Line(5) = {1, 5};
Line(6) = {5, 6};
Line(7) = {6, 2};
// east flap
Line(8) = {2, 7};
Line(9) = {7, 8};
Line(10) = {8, 3};
// north flap
Line(11) = {3, 9};
Line(12) = {9, 10};
Line(13) = {10, 4};
// west flap
Line(14) = {4, 11};
Line(15) = {11, 12};
Line(16) = {12, 1};

Curve Loop(1) = {1, 2, 3, 4};
Curve Loop(2) = {5, 6, 7, -1};
Curve Loop(3) = {8, 9, 10, -2};
Curve Loop(4) = {11, 12, 13, -3};
Curve Loop(5) = {14, 15, 16, -4};
For k In {1:5}
  Plane Surface(k) = {k};
EndFor
Transfinite Curve{1:16} = n + 1;
For k In {1:5}
  Transfinite Surface{k};
  If (quads)
    Recombine Surface{k};
  EndIf
EndFor

Physical Surface("centre") = {1};
Physical Surface("flap_south") = {2};
Physical Surface("flap_east") = {3};
Physical Surface("flap_north") = {4};
Physical Surface("flap_west") = {5};
Physical Curve("tips") = {6, 9, 12, 15};
