// A block on an inclined joint (SI units, m): a base slab 0.2 x 0.1 x 0.05 and a block
// 0.1 x 0.1 x 0.05 on its middle, joined face to face, the whole tilted by 30 degrees about y so
// that the joint dips along +x. Groups: volumes 'base' and 'block'; surfaces 'joint' (the
// block's underside, one surface of both volumes, so the mesh conforms to it) and 'bottom' (the
// base's underside). Each group is found by the box around its tilted corners.
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 0.2, 0.1, 0.05};
Box(2) = {0.05, 0, 0.05, 0.1, 0.1, 0.05};
Coherence;
a = -Pi / 6;  // the tilt about y: x' = x cos a + z sin a, z' = -x sin a + z cos a
Rotate {{0, 1, 0}, {0, 0, 0}, a} { Volume{:}; }
c = Cos(a);
s = Sin(a);
e = 1e-4;
// The box around the tilted rectangle x0..x1, z0..z1 (all y), as a list.
Macro Around
  xs[] = {x0 * c + z0 * s, x1 * c + z0 * s, x0 * c + z1 * s, x1 * c + z1 * s};
  zs[] = {-x0 * s + z0 * c, -x1 * s + z0 * c, -x0 * s + z1 * c, -x1 * s + z1 * c};
  box[] = {Min(Min(xs[0], xs[1]), Min(xs[2], xs[3])) - e, -e, Min(Min(zs[0], zs[1]), Min(zs[2], zs[3])) - e,
           Max(Max(xs[0], xs[1]), Max(xs[2], xs[3])) + e, 0.1 + e, Max(Max(zs[0], zs[1]), Max(zs[2], zs[3])) + e};
Return
x0 = 0; x1 = 0.2; z0 = 0; z1 = 0.05; Call Around;
Physical Volume("base") = Volume In BoundingBox{box[0], box[1], box[2], box[3], box[4], box[5]};
x0 = 0.05; x1 = 0.15; z0 = 0.05; z1 = 0.1; Call Around;
Physical Volume("block") = Volume In BoundingBox{box[0], box[1], box[2], box[3], box[4], box[5]};
x0 = 0.05; x1 = 0.15; z0 = 0.05; z1 = 0.05; Call Around;
Physical Surface("joint") = Surface In BoundingBox{box[0], box[1], box[2], box[3], box[4], box[5]};
x0 = 0; x1 = 0.2; z0 = 0; z1 = 0; Call Around;
Physical Surface("bottom") = Surface In BoundingBox{box[0], box[1], box[2], box[3], box[4], box[5]};
