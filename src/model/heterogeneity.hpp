#pragma once
// A heterogeneous rock: each CE6 of a material with `heterogeneity` scales its strengths by a
// factor drawn from a distribution of mean 1 (model/heterogeneity.cpp).
#include <cstdint>
#include <vector>

#include "model/model.hpp"

namespace fdem {

/// Draw `id` of distribution h: Weibull of modulus m scaled to mean 1, or normal of mean 1 and
/// relative deviation s (drawn again where it is not positive). It depends on h.seed and id
/// alone (a counter-based generator), so every rank count and backend gets the same.
real strength_draw(const Heterogeneity& h, std::uint64_t id);

/// Draw `id` of the second stream of h (each tet's Young's modulus): independent of the first.
real stiffness_draw(const Heterogeneity& h, std::uint64_t id);

/// Per tet of m (its id), its factor on E: a draw where its material is heterogeneous with
/// youngs_modulus, else 1. Empty where no material draws E.
std::vector<real> draw_tet_stiffness(const Scene& scene, const Model& m);

/// Per CE6 of m (its id), its strength factor: a draw where the CE6 has its material's own law
/// and the material is heterogeneous, else 1. Empty where no material is heterogeneous. Throws
/// InputError where a draw is too strong for the cohesive law at the CE6's size (its fracture
/// energy below the elastic energy at the peak), naming the material and the fix.
std::vector<real> draw_ce6_strengths(const Scene& scene, const Model& m);

}  // namespace fdem
