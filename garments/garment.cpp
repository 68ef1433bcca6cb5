#include "garments/garment.h"

namespace drape {

const Anchor* Garment::FindAnchor(std::string_view label) const {
  for (const Anchor& a : anchors)
    if (a.label == label) return &a;
  return nullptr;
}

}  // namespace drape
