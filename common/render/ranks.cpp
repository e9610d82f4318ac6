// The one-process Ranks (ranks.h) of the default build: nothing to join, agree on or combine.
#include "render/ranks.h"

namespace raylife {

struct Ranks::Mpi {};

Ranks::Ranks(int&, char**&, const std::atomic<int>* signals) : signals_(signals) {}

Ranks::~Ranks() = default;

int Ranks::checkpoint(int status, std::uint64_t, std::uint64_t) { return status; }

RenderResult Ranks::render(const Scene& scene, const Camera& camera, RenderSettings settings,
                           const TraceFunction& trace)
{
  return raylife::render(scene, camera, settings, trace);
}

RenderResult Ranks::render(const Scene& scene, const Camera& camera, RenderSettings settings,
                           const SplatTraceFunction& trace)
{
  return raylife::render(scene, camera, settings, trace);
}

RenderResult Ranks::render(const Scene& scene, const Camera& camera, RenderSettings settings,
                           const WavefrontWorkers& workers, std::size_t maxKeys)
{
  return raylife::render(scene, camera, settings, workers, maxKeys);
}

RenderResult Ranks::renderShared(RenderSettings settings,
                                 const std::function<RenderResult(const RenderSettings&)>& renderShare)
{
  return renderShare(settings);
}

} // namespace raylife
