// I-shaped plate in the box [0, W] x [0, H] (aspect ratio H/W, [N15]: 1): a bottom and a top
// flange of thickness t across the full width, joined by a centred web of width w.
//
//   +---------------+  y = H
//   |  top flange   |
//   +----+     +----+  y = H - t
//        | web |
//   +----+     +----+  y = t
//   | bottom flange |
//   +===============+  y = 0   (clamped)
//
// Facet groups: clamped (the bottom side y = 0) and boundary (the rest); cell group: plate.
// quads = 1 (default): structured quadrilaterals (seven transfinite blocks), quads = 0:
// unstructured triangles of size h.
// Parameters (override with dgplate: mesh.parameters = {h = 0.2, w = 1}):
DefineConstant[
  W = {4.0, Name "Parameters/W"},
  H = {4.0, Name "Parameters/H"},
  t = {1.0, Name "Parameters/t"},
  w = {1.5, Name "Parameters/w"},
  h = {0.25, Name "Parameters/h"},
  quads = {1, Choices{0, 1}, Name "Parameters/quads"}
];
If (!(W > 0 && H > 2 * t && t > 0 && w > 0 && w < W && h > 0))
  Error("i_shape.geo: need 0 < w < W, 0 < 2 t < H and h > 0");
EndIf
xl = (W - w) / 2;
xr = (W + w) / 2;
ys = {0, t, H - t, H};
xs = {0, xl, xr, W};
For j In {0:3}
  For i In {0:3}
    Point(4 * j + i + 1) = {xs[i], ys[j], 0, h};
  EndFor
EndFor
// horizontal lines: row j, segment i -> 3 j + i + 1 (1..12)
For j In {0:3}
  For i In {0:2}
    Line(3 * j + i + 1) = {4 * j + i + 1, 4 * j + i + 2};
  EndFor
EndFor
// vertical lines of the flanges and the web
Line(13) = {1, 5};
Line(14) = {2, 6};
Line(15) = {3, 7};
Line(16) = {4, 8};
Line(17) = {6, 10};
Line(18) = {7, 11};
Line(19) = {9, 13};
Line(20) = {10, 14};
Line(21) = {11, 15};
Line(22) = {12, 16};
Curve Loop(1) = {1, 14, -4, -13};
Curve Loop(2) = {2, 15, -5, -14};
Curve Loop(3) = {3, 16, -6, -15};
Curve Loop(4) = {5, 18, -8, -17};
Curve Loop(5) = {7, 20, -10, -19};
Curve Loop(6) = {8, 21, -11, -20};
Curve Loop(7) = {9, 22, -12, -21};
For s In {1:7}
  Plane Surface(s) = {s};
EndFor
If (quads)
  nside = Ceil(xl / h);
  nweb = Ceil(w / h);
  nt = Ceil(t / h);
  nh = Ceil((H - 2 * t) / h);
  Transfinite Curve{1, 3, 4, 6, 7, 9, 10, 12} = nside + 1;
  Transfinite Curve{2, 5, 8, 11} = nweb + 1;
  Transfinite Curve{13, 14, 15, 16, 19, 20, 21, 22} = nt + 1;
  Transfinite Curve{17, 18} = nh + 1;
  Transfinite Surface{1:7};
  Recombine Surface{1:7};
EndIf
Physical Curve("clamped") = {1, 2, 3};
Physical Curve("boundary") = {4, 6, 7, 9, 10, 11, 12, 13, 16, 17, 18, 19, 22};
Physical Surface("plate") = {1:7};
