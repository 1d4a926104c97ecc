// A slab across a tunnel (SI units, m): 24 x 24 m in x and z, 1 m thick along the tunnel's axis
// y, the tunnel 2.5 m in radius at the origin. A bedding plane at z = 1.5 m and a vertical joint
// at x = 1 m cross the slab and the tunnel. Volume groups 'tunnel' (the rock to excavate) and
// 'rock'; surface groups 'bedding' and 'vertical' (the joints) and the sides 'xmin', 'xmax',
// 'zmin', 'zmax', 'back' (y = 0) and 'front' (y = 1). Elements of 0.35 m at the tunnel, growing
// to 3 m at the sides.
SetFactory("OpenCASCADE");
W = 24; T = 1; R = 2.5; zb = 1.5; xv = 1;
Box(1) = {-W / 2, 0, -W / 2, W, T, W};
Cylinder(2) = {0, 0, 0, 0, T, 0, R};
Rectangle(10) = {-W / 2, 0, zb, W, T};
Point(100) = {xv, 0, -W / 2};
Point(101) = {xv, T, -W / 2};
Point(102) = {xv, T, W / 2};
Point(103) = {xv, 0, W / 2};
Line(100) = {100, 101};
Line(101) = {101, 102};
Line(102) = {102, 103};
Line(103) = {103, 100};
Curve Loop(100) = {100, 101, 102, 103};
Plane Surface(11) = {100};
BooleanFragments{ Volume{1, 2}; Delete; }{ Surface{10, 11}; Delete; }
e = 1e-6;
tunnel() = Volume In BoundingBox{-R - e, -e, -R - e, R + e, T + e, R + e};
rock() = Volume{:};
rock() -= tunnel();
Physical Volume("tunnel") = tunnel();
Physical Volume("rock") = rock();
Physical Surface("bedding") = Surface In BoundingBox{-W / 2 - e, -e, zb - e, W / 2 + e, T + e, zb + e};
Physical Surface("vertical") = Surface In BoundingBox{xv - e, -e, -W / 2 - e, xv + e, T + e, W / 2 + e};
Physical Surface("xmin") = Surface In BoundingBox{-W / 2 - e, -e, -W / 2 - e, -W / 2 + e, T + e, W / 2 + e};
Physical Surface("xmax") = Surface In BoundingBox{W / 2 - e, -e, -W / 2 - e, W / 2 + e, T + e, W / 2 + e};
Physical Surface("zmin") = Surface In BoundingBox{-W / 2 - e, -e, -W / 2 - e, W / 2 + e, T + e, -W / 2 + e};
Physical Surface("zmax") = Surface In BoundingBox{-W / 2 - e, -e, W / 2 - e, W / 2 + e, T + e, W / 2 + e};
Physical Surface("back") = Surface In BoundingBox{-W / 2 - e, -e, -W / 2 - e, W / 2 + e, e, W / 2 + e};
Physical Surface("front") = Surface In BoundingBox{-W / 2 - e, T - e, -W / 2 - e, W / 2 + e, T + e, W / 2 + e};
Field[1] = MathEval;
Field[1].F = "0.35 + 0.25 * Fabs(Sqrt(x * x + z * z) - 2.5)";
Background Field = 1;
