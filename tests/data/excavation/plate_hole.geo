// A quarter of a square plate, 10 m a side, with the quarter of a circular hole of 1 m radius
// at the origin (SI units, m), 0.25 m thick: volume groups 'rock' and 'hole' (the rock inside
// the hole, to be excavated). Sides: 'xsym' (x = 0), 'ysym' (y = 0), 'xfar' (x = 10), 'yfar'
// (y = 10), 'back' (z = 0), 'front' (z = 0.25). Elements of 0.1 m at the hole, 1 m far away.
SetFactory("OpenCASCADE");
a = 1; L = 10; t = 0.25;
Box(1) = {0, 0, 0, L, L, t};
Cylinder(2) = {0, 0, 0, 0, 0, t, a, Pi / 2};
BooleanFragments{ Volume{1}; Delete; }{ Volume{2}; Delete; }
e = 1e-6;
hole() = Volume In BoundingBox{-e, -e, -e, a + e, a + e, t + e};
all() = Volume{:};
rock() = all();
rock() -= hole();
Physical Volume("hole") = hole();
Physical Volume("rock") = rock();
Physical Surface("xsym") = Surface In BoundingBox{-e, -e, -e, e, L + e, t + e};
Physical Surface("ysym") = Surface In BoundingBox{-e, -e, -e, L + e, e, t + e};
Physical Surface("xfar") = Surface In BoundingBox{L - e, -e, -e, L + e, L + e, t + e};
Physical Surface("yfar") = Surface In BoundingBox{-e, L - e, -e, L + e, L + e, t + e};
Physical Surface("back") = Surface In BoundingBox{-e, -e, -e, L + e, L + e, e};
Physical Surface("front") = Surface In BoundingBox{-e, -e, t - e, L + e, L + e, t + e};
Field[1] = MathEval;
Field[1].F = "0.1 + 0.15 * Fabs(Sqrt(x * x + y * y) - 1)";
Background Field = 1;
Mesh.MeshSizeExtendFromBoundary = 0;
Mesh.MeshSizeFromPoints = 0;
Mesh.MeshSizeFromCurvature = 0;
