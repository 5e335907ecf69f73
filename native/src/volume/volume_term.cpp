#include "volume/volume_term.h"

#include "volume/bulk_term.h"
#include "volume/global_volume_term.h"

namespace arap {

std::unique_ptr<VolumeTerm> make_volume_term(Volume mode, BoundMesh& mesh, const Triangles& triangles,
                                             const InfillGraph& lattice) {
  if (mode == Volume::Infill) {
    auto term = std::make_unique<BulkTerm>();
    term->bulk().bind(mesh, lattice, kInfillBulk);
    if (term->bulk().active()) return term;
  } else if (mode == Volume::Global) {
    auto term = std::make_unique<GlobalVolumeTerm>();
    term->bind(mesh, triangles);
    mesh.report.volume_kept_components = term->constraint().kept_components();
    mesh.report.volume_open_components = term->constraint().open_components();
    if (term->constraint().active()) return term;
  }
  return nullptr;
}

}  // namespace arap
