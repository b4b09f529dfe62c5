#include "common/material/interface.h"

namespace lensfarm {

BsdfTraits InterfaceBsdf::traits() const {
  BsdfTraits t;
  t.passesThrough = true;
  t.transmits = true;
  t.choosesLobe = false;
  t.effect = "medium boundary";
  return t;
}

std::shared_ptr<const Bsdf> parseInterface(FieldReader& /*r*/) { return std::make_shared<InterfaceBsdf>(); }

}  // namespace lensfarm
