#include "loads/loads.hpp"

namespace fdem {

Loads make_loads(const Scene& scene, const Model& m, real wave_speed) {
  Loads l;
  const real transits = 10 * m.height0 / wave_speed;
  l.platens.set_up(scene, m, transits);
  l.surface.set_up(scene, m, transits);
  l.gravity.set_up(scene);
  l.prescribed.set_up(scene, m);
  return l;
}

}  // namespace fdem
