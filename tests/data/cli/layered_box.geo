// A 10 x 10 x 20 mm box in two layers of 10 mm (SI units, m): volume groups 'lower' and
// 'upper', and the box's six sides named as a generated box's.
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 0.01, 0.01, 0.01};
Box(2) = {0, 0, 0.01, 0.01, 0.01, 0.01};
Coherence;
e = 1e-6;
Physical Volume("lower") = {1};
Physical Volume("upper") = {2};
Physical Surface("xmin") = Surface In BoundingBox{-e, -e, -e, e, 0.01 + e, 0.02 + e};
Physical Surface("xmax") = Surface In BoundingBox{0.01 - e, -e, -e, 0.01 + e, 0.01 + e, 0.02 + e};
Physical Surface("ymin") = Surface In BoundingBox{-e, -e, -e, 0.01 + e, e, 0.02 + e};
Physical Surface("ymax") = Surface In BoundingBox{-e, 0.01 - e, -e, 0.01 + e, 0.01 + e, 0.02 + e};
Physical Surface("zmin") = Surface In BoundingBox{-e, -e, -e, 0.01 + e, 0.01 + e, e};
Physical Surface("zmax") = Surface In BoundingBox{-e, -e, 0.02 - e, 0.01 + e, 0.01 + e, 0.02 + e};
