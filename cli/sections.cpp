#include "cli/sections.h"

namespace drape::cli {

using registration::RegistrationOptions;

const ConfigSection<RegistrationOptions> kRegistrationSection(
    "registration",
    "Registration of a mesh onto a reconstruction (`drape register`, and the registration table of `drape "
    "eval`): scale, rigid ICP on a closest-point grid, non-rigid secant Levenberg–Marquardt.",
    {{"scale", Ref(&RegistrationOptions::scale), "bool", "scale the source to the target's size first"},
     {"grid_cells", Ref(&RegistrationOptions::grid, &registration::GridOptions::cells), "cells",
      "closest-point grid cells along the longest side"},
     {"refined_query", Ref(&RegistrationOptions::icp, &registration::IcpOptions::refined_query), "bool",
      "ICP's distance: exact to the ≤ 8 triangles a grid cell stores; false: the paper's 8-point query"},
     {"refined_fit", Ref(&RegistrationOptions::refined_fit), "bool", "the fitting term's distance, as refined_query"},
     {"kappa", Ref(&RegistrationOptions::kappa), "m²", "weight κ of E_area"},
     {"beta", Ref(&RegistrationOptions::beta), "m²", "weight β of E_angle"},
     {"alpha", Ref(&RegistrationOptions::alpha), "m⁴", "weight α of E_hinge"},
     {"iterations", Ref(&RegistrationOptions::lm, &optim::SecantLmOptions::max_iterations), "",
      "most Levenberg–Marquardt iterations of the non-rigid step"}});

}  // namespace drape::cli
