// The net of a self-folding box ([N15], "Self-Assembling Composite-Material Box"):
// six unit squares in a cross, joined by hinge strips of width w (π/24 in [N15]).
//
//                 +-----+
//                 | lid |        y = 2+2w .. 3+2w   (free edge "lid_edge" at y = 3+2w)
//                 +-----+  hinge_lid
//                 |north|        y = 1+w .. 2+w
//                 +-----+  hinge_north
//   +----+-+------+-----+------+-+----+
//   |west| |      |base |      | |east|   base = [0,1]²; hinge_west, hinge_east
//   +----+-+------+-----+------+-+----+
//                 +-----+  hinge_south
//                 |south|        y = -1-w .. -w
//                 +-----+
//
// Structured mesh: every face has n×n cells, every hinge m cells across and n along
// (the hinges need m >= 2 to bend smoothly). quads = 1: quadrilaterals (Q2 in dgplate).
// Cell groups: base, north, south, east, west, lid, hinge_north, hinge_south, hinge_east,
// hinge_west, hinge_lid. Facet group: lid_edge (the lid's free edge, used to measure closure).
DefineConstant[
  w = {Pi/24, Name "Parameters/w"},
  n = {4, Name "Parameters/n"},
  m = {2, Name "Parameters/m"},
  quads = {1, Choices{0, 1}, Name "Parameters/quads"}
];

// Tensor grid of points: columns X (west face, west hinge, centre, east hinge, east face) and
// rows Y (south face, south hinge, base row, north hinge, north face, lid hinge, lid).
X[] = {-1 - w, -w, 0, 1, 1 + w, 2 + w};
Y[] = {-1 - w, -w, 0, 1, 1 + w, 2 + w, 2 + 2*w, 3 + 2*w};
For j In {0:7}
  For i In {0:5}
    Point(1 + i + 6*j) = {X[i], Y[j], 0};
  EndFor
EndFor

// Lines of the whole grid (those outside the net are meshed but belong to no group):
// horizontal H(i,j) = 1000 + i + 5j from point (i,j) to (i+1,j), vertical
// V(i,j) = 2000 + i + 6j from (i,j) to (i,j+1). Odd columns/rows are hinges (m cells).
For j In {0:7}
  For i In {0:4}
    Line(1000 + i + 5*j) = {1 + i + 6*j, 2 + i + 6*j};
    Transfinite Curve{1000 + i + 5*j} = ((i == 1 || i == 3) ? m : n) + 1;
  EndFor
EndFor
For j In {0:6}
  For i In {0:5}
    Line(2000 + i + 6*j) = {1 + i + 6*j, 1 + i + 6*(j + 1)};
    Transfinite Curve{2000 + i + 6*j} = ((j == 1 || j == 3 || j == 5) ? m : n) + 1;
  EndFor
EndFor

// The grid cells (column i, row j) that form the net, in the order of the groups below.
cols[] = {0, 1, 2, 3, 4, 2, 2, 2, 2, 2, 2};
rows[] = {2, 2, 2, 2, 2, 0, 1, 3, 4, 5, 6};
For k In {0:10}
  i = cols[k];
  j = rows[k];
  Curve Loop(100 + k) = {1000 + i + 5*j, 2000 + i + 1 + 6*j, -(1000 + i + 5*(j + 1)), -(2000 + i + 6*j)};
  Plane Surface(100 + k) = {100 + k};
  Transfinite Surface{100 + k};
  If (quads)
    Recombine Surface{100 + k};
  EndIf
EndFor

Physical Surface("west") = {100};
Physical Surface("hinge_west") = {101};
Physical Surface("base") = {102};
Physical Surface("hinge_east") = {103};
Physical Surface("east") = {104};
Physical Surface("south") = {105};
Physical Surface("hinge_south") = {106};
Physical Surface("hinge_north") = {107};
Physical Surface("north") = {108};
Physical Surface("hinge_lid") = {109};
Physical Surface("lid") = {110};
Physical Curve("lid_edge") = {1000 + 2 + 5*7};
