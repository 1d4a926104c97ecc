// A quarter of a thick-walled cylinder, inner radius 10 mm, outer 30 mm, 5 mm tall (SI units,
// m). Its surfaces are named for the conditions of a plane-strain Lame test: the inner and
// outer walls, the two symmetry planes and the two ends.
SetFactory("OpenCASCADE");
Cylinder(1) = {0, 0, 0, 0, 0, 0.005, 0.03, Pi / 2};
Cylinder(2) = {0, 0, 0, 0, 0, 0.005, 0.01, Pi / 2};
BooleanDifference(3) = { Volume{1}; Delete; }{ Volume{2}; Delete; };
e = 1e-6;
inner() = Surface In BoundingBox{-e, -e, -e, 0.01 + e, 0.01 + e, 0.005 + e};
bottom() = Surface In BoundingBox{-e, -e, -e, 0.03 + e, 0.03 + e, e};
top() = Surface In BoundingBox{-e, -e, 0.005 - e, 0.03 + e, 0.03 + e, 0.005 + e};
xsym() = Surface In BoundingBox{-e, -e, -e, e, 0.03 + e, 0.005 + e};
ysym() = Surface In BoundingBox{-e, -e, -e, 0.03 + e, e, 0.005 + e};
outer() = Abs(Boundary{ Volume{3}; });
outer() -= {inner(), bottom(), top(), xsym(), ysym()};
Physical Volume("rock") = {3};
Physical Surface("inner") = {inner()};
Physical Surface("outer") = {outer()};
Physical Surface("bottom") = {bottom()};
Physical Surface("top") = {top()};
Physical Surface("xsym") = {xsym()};
Physical Surface("ysym") = {ysym()};
