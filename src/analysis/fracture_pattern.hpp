#pragma once
// Statistics of a fracture pattern: the broken CE6 faces by mode and an estimate of the main
// failure plane.
//
// Failure plane: the area-weighted principal axes of the broken faces' centroids (reference
// configuration). With weights w_i = a_i and centroid c = sum w_i p_i / sum w_i, the covariance
// C = sum w_i (p_i - c)(p_i - c)^T / sum w_i has eigenvalues l1 >= l2 >= l3; the eigenvector of
// l3 is the normal n of the best-fit plane. Its angle to the loading axis a (unit) is
//   theta = asin(|n . a|)        (0 deg: an axial split; 90 deg: a plane normal to the load).
// planarity = 1 - l3 / l2 says whether one plane describes the cracks (near 1) or they are
// scattered through the volume (near 0), in which case theta means little.
// The facet angle asin(|n_f . a|) of each broken face, area-weighted and averaged, is reported
// too: it describes the crack surfaces themselves, which zigzag along element faces.
#include <array>
#include <vector>

#include "core/vec.hpp"

namespace fdem {

struct FracturePattern {
  long broken = 0, mode_I = 0, mode_II = 0, mixed = 0;
  real area = 0;                  // m^2, total area of the broken faces (reference configuration)
  Vec3 centroid{0, 0, 0};         // m
  Vec3 plane_normal{0, 0, 0};     // unit normal of the best-fit plane (0 with fewer than 3 faces)
  real plane_angle_deg = 0;       // angle between the best-fit plane and the loading axis, degrees
  real planarity = 0;             // 1 - l3/l2 in [0,1]
  real mean_facet_angle_deg = 0;  // area-weighted mean angle of the faces to the loading axis, degrees
};

/// faces: the three corner positions of each broken face; mode: 1 (I), 2 (II) or 3 (mixed) per
/// face; axis: the loading direction (need not be unit). NaN-free input is assumed.
FracturePattern fracture_pattern(const std::vector<std::array<Vec3, 3>>& faces, const std::vector<int>& mode,
                                 Vec3 axis);

/// Eigenvalues (ascending) and unit eigenvectors (columns, in the same order) of a symmetric 3x3
/// matrix, by cyclic Jacobi rotations.
void symmetric_eigen3(const real a[3][3], real values[3], Vec3 vectors[3]);

}  // namespace fdem
