#include "shading/medium.h"

#include "core/frame.h"

namespace raylife {

PhaseSample sampleHg(const Vec3& w, Real g, Vec2 u)
{
  const Real cosTheta = sampleHgCosTheta(g, u.x);
  const Real sinTheta = std::sqrt(std::max(Real(0), (1 - cosTheta) * (1 + cosTheta)));
  const SinCos<Real> phi = sinCos2Pi(u.y);
  const Frame frame = Frame::fromNormal(w);
  const Vec3 wi = glm::normalize(frame.toWorld(Vec3(sinTheta * phi.cos, sinTheta * phi.sin, cosTheta)));
  return PhaseSample{wi, hgPhase(cosTheta, g)};
}

} // namespace raylife
