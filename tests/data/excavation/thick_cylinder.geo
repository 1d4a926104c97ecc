// A quarter of a thick-walled cylinder (SI units, m): inner radius 1, outer 4, 0.25 thick along
// z. Volume group 'wall'; surfaces 'inner' (r = 1, the bore), 'xsym' (x = 0), 'ysym' (y = 0),
// 'back' (z = 0) and 'front' (z = 0.25); the outside (r = 4) is free. Elements of 0.08 m at the
// bore, 0.5 m outside.
SetFactory("OpenCASCADE");
a = 1; b = 4; t = 0.25;
Cylinder(1) = {0, 0, 0, 0, 0, t, b, Pi / 2};
Cylinder(2) = {0, 0, 0, 0, 0, t, a, Pi / 2};
BooleanDifference(3) = { Volume{1}; Delete; }{ Volume{2}; Delete; };
e = 1e-6;
Physical Volume("wall") = {3};
Physical Surface("xsym") = Surface In BoundingBox{-e, -e, -e, e, b + e, t + e};
Physical Surface("ysym") = Surface In BoundingBox{-e, -e, -e, b + e, e, t + e};
Physical Surface("back") = Surface In BoundingBox{-e, -e, -e, b + e, b + e, e};
Physical Surface("front") = Surface In BoundingBox{-e, -e, t - e, b + e, b + e, t + e};
Physical Surface("inner") = Surface In BoundingBox{-e, -e, -e, a + e, a + e, t + e};
Field[1] = MathEval;
Field[1].F = "0.08 + 0.15 * (Sqrt(x * x + y * y) - 1)";
Background Field = 1;
