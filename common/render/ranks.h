/// @file ranks.h
/// @brief The processes that render one image together: one, or the ranks of an MPI job (a build with
/// RAYLIFE_MPI=ON run under mpirun). The runner (runner.h) goes through this narrow interface; everything MPI
/// lives in ranks_mpi.cpp, and ranks.cpp is the one-process version the default build links.
#pragma once

#include "render/render_loop.h"

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

namespace raylife {

/// A rank's way out of the run: some rank failed (its message has been printed by rank 0), and every rank ends
/// with `status` without another collective step. Not a std::exception, so that no general handler takes it.
struct RanksStopped {
  int status; ///< The exit status every rank returns.
};

/// The ranks of a render (docs/beyond-one-machine.md). Only rank 0 speaks and writes: on every other rank,
/// standard output and standard error are held back, and what a failing rank said reaches rank 0 through
/// checkpoint(). Collective calls (checkpoint, render, finish) must be reached by every rank in the same order.
class Ranks {
public:
  /// Joins the job (MPI_Init; the render loop's threads never call MPI). One process: nothing to join.
  /// `signals`, if not null, counts the stop signals received (SIGINT, SIGTERM): a rank that has one and still
  /// waits for the others half a second later takes the job as ended (mpirun sends SIGTERM to every rank when
  /// one dies, and SIGKILL a second later), says so on rank 0, and exits without writing.
  Ranks(int& argc, char**& argv, const std::atomic<int>* signals);
  ~Ranks();
  Ranks(const Ranks&) = delete;
  Ranks& operator=(const Ranks&) = delete;

  /// This process's rank, in [0, size()).
  int rank() const { return rank_; }
  /// How many ranks render the image (1 without MPI).
  int size() const { return size_; }
  /// True on rank 0, the one that writes files and prints.
  bool root() const { return rank_ == 0; }

  /// Collective: every rank says how it is (`status`, 0: ready) and what it is about to render (`sceneHash`, the
  /// hash of its scene file and of its meshes' geometry, and `settingsHash`, of the render's settings). Returns 0
  /// when every rank is ready and all agree with rank 0; otherwise the status every rank must end with, rank 0 having printed one message:
  /// the first failing rank's own, or which rank's scene file or settings differ.
  int checkpoint(int status, std::uint64_t sceneHash = 0, std::uint64_t settingsHash = 0);

  /// Collective: renders this rank's share of the samples (by sample index: with `spp`, rank r of N takes the
  /// indices [spp·r/N, spp·(r+1)/N); with `seconds`, every Nth block of kSampleBlock; SampleShare) and sums the
  /// shares exactly onto rank 0. On every rank the result's totals are the job's: spp and meanSpp the samples
  /// per pixel over all ranks, rays and bad samples summed, seconds the longest rank's, interrupted if any rank
  /// was; `samples` and the film are the whole job's on rank 0, this rank's own elsewhere. Progress is drawn by
  /// rank 0 only. @throws RanksStopped when a rank failed.
  RenderResult render(const Scene& scene, const Camera& camera, RenderSettings settings, const TraceFunction& trace);
  /// The same for an estimator that splats (chapter 13): a share of the sample indices holds whole passes, so each
  /// rank's film holds every splat of its passes and the shares sum exactly as well.
  RenderResult render(const Scene& scene, const Camera& camera, RenderSettings settings,
                      const SplatTraceFunction& trace);
  /// The same for a wavefront estimator (chapter 16), one made by `workers` for each thread, handed pieces of at
  /// most `maxKeys` pixel samples.
  RenderResult render(const Scene& scene, const Camera& camera, RenderSettings settings,
                      const WavefrontWorkers& workers, std::size_t maxKeys);

  /// Seconds the last render() spent combining the ranks' films (0 for one process).
  double combineSeconds() const { return combineSeconds_; }

  /// Collective, the last: every rank gives its exit status; returns the one to exit with (the first failing
  /// rank's, after rank 0 has printed its message; the most severe otherwise).
  int finish(int status) { return checkpoint(status); }

private:
  // Both render()s: `renderShare` renders the settings' share on this rank; the shares are then combined.
  RenderResult renderShared(RenderSettings settings,
                            const std::function<RenderResult(const RenderSettings&)>& renderShare);
  struct Mpi; // the MPI state (ranks_mpi.cpp)
  int rank_ = 0;
  int size_ = 1;
  double combineSeconds_ = 0;
  [[maybe_unused]] const std::atomic<int>* signals_ = nullptr; // (read by the MPI build only)
  std::unique_ptr<Mpi> mpi_;
};

} // namespace raylife
