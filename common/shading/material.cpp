#include "shading/material.h"

namespace raylife {

const char* materialTypeName(MaterialType type)
{
  switch (type) {
  case MaterialType::Diffuse: return "diffuse";
  case MaterialType::Mirror: return "mirror";
  case MaterialType::Glass: return "glass";
  case MaterialType::Glossy: return "glossy";
  case MaterialType::Metal: return "metal";
  case MaterialType::Interface: return "interface";
  }
  return "unknown";
}

} // namespace raylife
