// Strength draws of heterogeneous rock. Counter-based: draw k of a seed is a hash of the two,
// so the draws need no stream state and do not depend on the order CE6s are visited in.
#include "model/heterogeneity.hpp"

#include <cmath>

#include "core/error.hpp"
#include "core/format.hpp"
#include "model/laws.hpp"

namespace fdem {

namespace {

/// SplitMix64's finaliser: a bijection of 64-bit words that mixes every bit into every other.
std::uint64_t mix(std::uint64_t z) {
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

/// Uniform in (0, 1), never 0 or 1: number `k` of draw `id` of `seed`.
real uniform(std::uint64_t seed, std::uint64_t id, std::uint64_t k) {
  const std::uint64_t z = mix(mix(mix(seed + 0x9e3779b97f4a7c15ull) ^ id) ^ k);
  return (real(z >> 12) + real(0.5)) * real(1.0 / 4503599627370496.0);  // 2^-52: 2^-53 .. 1 - 2^-53, exact
}

/// Draw `id` of distribution h from the stream of `seed` (h.seed, or one made from it).
real draw(const Heterogeneity& h, std::uint64_t seed, std::uint64_t id) {
  constexpr real kTwoPi = real(6.283185307179586);
  switch (h.distribution) {
    case StrengthSpread::weibull: {
      // Inverse CDF, F(s) = 1 - exp(-(s/lambda)^m), with lambda = 1/Gamma(1 + 1/m) for mean 1.
      const real lambda = 1 / std::tgamma(1 + 1 / h.modulus);
      return lambda * std::pow(-std::log(uniform(seed, id, 0)), 1 / h.modulus);
    }
    case StrengthSpread::normal:
      for (std::uint64_t k = 0;; k += 2) {  // Box-Muller; a draw <= 0 is drawn again
        const real z = std::sqrt(-2 * std::log(uniform(seed, id, k))) * std::cos(kTwoPi * uniform(seed, id, k + 1));
        const real s = 1 + h.deviation * z;
        if (s > 0) return s;
      }
    default:
      return 1;
  }
}

}  // namespace

real strength_draw(const Heterogeneity& h, std::uint64_t id) {
  return draw(h, h.seed, id);
}

real stiffness_draw(const Heterogeneity& h, std::uint64_t id) {
  return draw(h, mix(h.seed ^ 0x5713ff2e55c0ffeeull), id);  // another seed: another stream
}

std::vector<real> draw_tet_stiffness(const Scene& scene, const Model& m) {
  bool any = false;
  for (const Material& mat : scene.materials) any = any || (mat.heterogeneity.on() && mat.heterogeneity.youngs_modulus);
  if (!any) return {};
  std::vector<real> factor(m.tet_nodes.size(), 1);
  for (std::size_t t = 0; t < factor.size(); ++t) {
    const Heterogeneity& h = scene.materials[m.tet_material[t]].heterogeneity;
    if (h.on() && h.youngs_modulus) factor[t] = stiffness_draw(h, t);
  }
  return factor;
}

std::vector<real> draw_ce6_strengths(const Scene& scene, const Model& m) {
  bool any = false;
  for (const Material& mat : scene.materials) any = any || mat.heterogeneity.on();
  if (!any) return {};
  std::vector<real> factor(m.ce6_nodes.size(), 1);
  for (std::size_t c = 0; c < factor.size(); ++c) {
    const int law = m.ce6_law[c];
    if (law >= int(scene.materials.size()) || !scene.materials[law].heterogeneity.on()) continue;
    const Material& mat = scene.materials[law];
    factor[c] = strength_draw(mat.heterogeneity, c);
    const real limit = largest_strength_factor(make_ce6_params(mat), m.ce6_h[c]);
    if (!(factor[c] < limit))
      throw InputError(
          scene.file + ": " +
          (mat.name.empty() ? std::string("material") : "materials[" + std::to_string(law) + "] ('" + mat.name + "')") +
          ".heterogeneity: CE6 " + std::to_string(c + 1) + " drew strength factor " + fmt(factor[c], 4) +
          ", beyond the " + fmt(limit, 4) + " its cohesive law takes at its size (" + fmt(m.ce6_h[c], 4) +
          " m); narrow the spread (a larger modulus or a smaller deviation), or raise the fracture "
          "energies or the cohesive penalties");
  }
  return factor;
}

}  // namespace fdem
