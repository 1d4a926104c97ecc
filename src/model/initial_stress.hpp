#pragma once
// The in-situ stress in the model (scene initial_stress): each tet starts with the stress at its
// reference centroid, and each CE6 with the opening offsets that make its law carry the matching
// traction at zero gap. With tractions that are linear over a face, as a linear field gives,
// the CE6s' three points give each node its exact share: an interior node starts in
// equilibrium, gravity included.
#include <string>

#include "model/laws.hpp"
#include "model/model.hpp"
#include "scene/scene.hpp"

namespace fdem {

/// Fills m.tet_initial_stress and m.ce6_prestress from the scene (both empty where it has no
/// initial_stress). Throws InputError, naming the scene key and the fix, where a geostatic
/// surface lies below the rock, or where the in-situ traction on a CE6 reaches its strength (or
/// a frictional joint's friction), since that rock could not start at rest.
void place_initial_stress(const Scene& scene, const ElementLaws& laws, Model& m);

/// fdem check's line for the in-situ stress ("" where the scene has none).
std::string describe_initial_stress(const Scene& scene);

}  // namespace fdem
