// The MPI Ranks (ranks.h) of the MPI build (cmake --preset mpi): every rank renders its share of the sample
// indices, and the films' fixed-point sums are added onto rank 0 by an MPI reduce, which integer addition makes
// exact in any order (docs/beyond-one-machine.md). Only the main thread calls MPI (MPI_THREAD_FUNNELED).
#include "render/ranks.h"

#include "render/film_file.h"

#include <mpi.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <sstream>
#include <thread>

#include <unistd.h>

namespace raylife {

namespace {

using Clock = std::chrono::steady_clock;

// Pixels per step of the film's reduce: bounds the extra memory of rank 0 and of MPI's buffers to a few MB.
constexpr std::size_t kReducePixels = std::size_t(1) << 16;
// How long rank 0 still waits for the other ranks once it has been sent a stop signal: mpirun sends SIGTERM to
// every rank when one dies (or when it is interrupted) and SIGKILL a second later; ranks that were merely
// interrupted reach the next step within a pass (a quarter of a second), a dead one never does.
constexpr double kStopGraceSeconds = 0.5;

// What rank 0 says when the job ends under it while it waits for the other ranks (a peer died, or mpirun was
// interrupted: either way the films can no longer be combined). Filled in before any wait; a signal handler may only
// write it out (async-signal-safe), hence a fixed buffer here rather than a std::string.
char gStoppedMessage[512];
std::size_t gStoppedLength = 0;
bool gStoppedSays = false; // this process is rank 0

[[noreturn]] void stopWithoutWriting()
{
  if (gStoppedSays) {
    [[maybe_unused]] const ssize_t ignored = ::write(STDERR_FILENO, gStoppedMessage, gStoppedLength);
  }
  _exit(1);
}

extern "C" void onStopWhileCombining(int) { stopWithoutWriting(); }

// While the films are being combined (blocking MPI calls: the non-blocking ones move large buffers several times
// slower), a stop signal means the job is ending under us: say so on rank 0 and exit. Installed for its lifetime.
class CombiningHandlers {
public:
  CombiningHandlers()
  {
    struct sigaction action{};
    action.sa_handler = onStopWhileCombining;
    sigemptyset(&action.sa_mask);
    sigaction(SIGINT, &action, &previousInt_);
    sigaction(SIGTERM, &action, &previousTerm_);
  }
  ~CombiningHandlers()
  {
    sigaction(SIGINT, &previousInt_, nullptr);
    sigaction(SIGTERM, &previousTerm_, nullptr);
  }
  CombiningHandlers(const CombiningHandlers&) = delete;
  CombiningHandlers& operator=(const CombiningHandlers&) = delete;

private:
  struct sigaction previousInt_{};
  struct sigaction previousTerm_{};
};

// Adds arrays of Fixed128 (an MPI user operation: exact, associative and commutative).
extern "C" void addFixed(void* in, void* inout, int* length, MPI_Datatype*)
{
  const auto* a = static_cast<const Fixed128*>(in);
  auto* b = static_cast<Fixed128*>(inout);
  for (int i = 0; i < *length; ++i)
    b[i] += a[i];
}

// What every rank says at a checkpoint.
struct Report {
  std::int64_t status;
  std::uint64_t sceneHash;
  std::uint64_t settingsHash;
  std::int64_t messageBytes;
};

} // namespace

struct Ranks::Mpi {
  bool initialised = false;    // whether this object called MPI_Init (and so calls MPI_Finalize)
  std::string program;         // argv[0]'s file name, for rank 0's messages
  std::ostringstream heldBack; // what a rank other than 0 said since the last checkpoint
  std::streambuf* coutBuffer = nullptr;
  std::streambuf* cerrBuffer = nullptr;
  MPI_Datatype fixedType = MPI_DATATYPE_NULL;
  MPI_Op addOp = MPI_OP_NULL;

  // Waits for `request`, calling MPI_Test (which moves a non-blocking operation on), gently after a while: a
  // checkpoint may wait long for ranks still rendering on this machine's cores. Rank 0, once stopped by a signal,
  // waits kStopGraceSeconds more and then ends the job with one message (the others may be dead: nothing will
  // come).
  void wait(MPI_Request& request, bool root, const std::atomic<int>* signals) const
  {
    std::optional<Clock::time_point> stopped;
    for (int polls = 0;; ++polls) {
      int done = 0;
      MPI_Test(&request, &done, MPI_STATUS_IGNORE);
      if (done)
        return;
      if (root && signals && signals->load() > 0) {
        if (!stopped)
          stopped = Clock::now();
        else if (std::chrono::duration<double>(Clock::now() - *stopped).count() > kStopGraceSeconds)
          stopWithoutWriting();
      }
      if (polls > 1000) // then poll gently: the ranks still rendering on this machine need its cores
        std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
  }
};

Ranks::Ranks(int& argc, char**& argv, const std::atomic<int>* signals) : signals_(signals), mpi_(new Mpi)
{
  int already = 0;
  MPI_Initialized(&already);
  if (!already) {
    int provided = 0;
    MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
    mpi_->initialised = true;
  }
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &size_);
  const std::string path = argc > 0 ? argv[0] : "raylife";
  mpi_->program = path.substr(path.rfind('/') + 1);
  MPI_Type_contiguous(2, MPI_UINT64_T, &mpi_->fixedType);
  MPI_Type_commit(&mpi_->fixedType);
  MPI_Op_create(addFixed, 1, &mpi_->addOp);
  const std::string stopped = mpi_->program + ": the job was stopped while rank 0 waited for the other ranks (a rank "
                                              "died, or mpirun was interrupted); nothing was written\n";
  gStoppedLength = std::min(stopped.size(), sizeof gStoppedMessage);
  std::memcpy(gStoppedMessage, stopped.data(), gStoppedLength);
  gStoppedSays = rank_ == 0;
  if (rank_ != 0) { // only rank 0 speaks
    mpi_->coutBuffer = std::cout.rdbuf(mpi_->heldBack.rdbuf());
    mpi_->cerrBuffer = std::cerr.rdbuf(mpi_->heldBack.rdbuf());
  }
}

Ranks::~Ranks()
{
  if (mpi_->coutBuffer) {
    std::cout.rdbuf(mpi_->coutBuffer);
    std::cerr.rdbuf(mpi_->cerrBuffer);
  }
  MPI_Op_free(&mpi_->addOp);
  MPI_Type_free(&mpi_->fixedType);
  if (mpi_->initialised)
    MPI_Finalize();
}

int Ranks::checkpoint(int status, std::uint64_t sceneHash, std::uint64_t settingsHash)
{
  // Every rank's report to every rank, so that all reach the same verdict.
  std::string message = mpi_->heldBack.str();
  mpi_->heldBack.str("");
  message = message.substr(0, message.find('\n')); // its first line: the fault (a usage hint may follow)
  const Report mine{status, sceneHash, settingsHash, std::int64_t(message.size())};
  std::vector<Report> all(static_cast<std::size_t>(size_));
  MPI_Request request;
  MPI_Iallgather(&mine, int(sizeof mine), MPI_BYTE, all.data(), int(sizeof mine), MPI_BYTE, MPI_COMM_WORLD, &request);
  mpi_->wait(request, root(), signals_);

  for (int r = 0; r < size_; ++r) {
    const Report& report = all[std::size_t(r)];
    if (report.status == 0)
      continue;
    // The first failing rank: rank 0 has said its own fault; another's comes to rank 0 to be said.
    if (r != 0 && (rank_ == r || root())) {
      std::string text(std::size_t(report.messageBytes), '\0');
      if (rank_ == r)
        text = message;
      MPI_Request transfer;
      if (rank_ == r)
        MPI_Isend(text.data(), int(text.size()), MPI_CHAR, 0, 0, MPI_COMM_WORLD, &transfer);
      else
        MPI_Irecv(text.data(), int(text.size()), MPI_CHAR, r, 0, MPI_COMM_WORLD, &transfer);
      mpi_->wait(transfer, root(), signals_);
      if (root())
        std::cerr << (text.empty() ? mpi_->program + ": failed" : text) << " (on rank " << r << ")\n";
    }
    return int(report.status);
  }
  for (int r = 1; r < size_; ++r) {
    const Report& report = all[std::size_t(r)];
    const char* what = report.sceneHash != all[0].sceneHash
                           ? "the scene file differs between ranks: rank %d read other bytes than rank 0 (every rank "
                             "must render the same scene: copy the same file to every machine)\n"
                       : report.settingsHash != all[0].settingsHash
                           ? "the command line differs between ranks: rank %d would render another image than rank "
                             "0 (size, spp, seed, depth or time)\n"
                           : nullptr;
    if (what) {
      if (root()) {
        char line[256];
        std::snprintf(line, sizeof line, what, r);
        std::cerr << mpi_->program << ": " << line;
      }
      return 1;
    }
  }
  return 0;
}

RenderResult Ranks::render(const Scene& scene, const Camera& camera, RenderSettings settings,
                           const TraceFunction& trace)
{
  return renderShared(settings,
                      [&](const RenderSettings& share) { return raylife::render(scene, camera, share, trace); });
}

RenderResult Ranks::render(const Scene& scene, const Camera& camera, RenderSettings settings,
                           const SplatTraceFunction& trace)
{
  return renderShared(settings,
                      [&](const RenderSettings& share) { return raylife::render(scene, camera, share, trace); });
}

RenderResult Ranks::render(const Scene& scene, const Camera& camera, RenderSettings settings,
                           const WavefrontWorkers& workers, std::size_t maxKeys)
{
  return renderShared(settings, [&](const RenderSettings& share) {
    return raylife::render(scene, camera, share, workers, maxKeys);
  });
}

RenderResult Ranks::renderShared(RenderSettings settings,
                                 const std::function<RenderResult(const RenderSettings&)>& renderShare)
{
  combineSeconds_ = 0;
  if (size_ == 1)
    return renderShare(settings);

  // This rank's share: a run of the sample indices of --spp (or of --samples' range), or blocks in turn for a
  // time budget.
  if (settings.spp) {
    const SampleRange whole = settings.share.range.value_or(SampleRange{0, *settings.spp});
    const int first = whole.first + int(std::int64_t(whole.count) * rank_ / size_);
    const int end = whole.first + int(std::int64_t(whole.count) * (rank_ + 1) / size_);
    settings.share.range = SampleRange{first, end - first};
  } else {
    settings.share.rank = rank_;
    settings.share.ranks = size_;
  }
  settings.progress = settings.progress && root();
  RenderResult mine = renderShare(settings);
  if (const char* kill = std::getenv("RAYLIFE_TEST_KILL_RANK"); kill && std::atoi(kill) == rank_)
    std::raise(SIGKILL); // tests only: a rank that dies before the films are combined

  // Every rank rendered its share (one that failed has said so: then all stop here).
  if (const int failed = checkpoint(0))
    throw RanksStopped{failed};
  const auto start = Clock::now();

  // Every rank is here: combine with blocking calls, under handlers that end the job if it ends under us.
  const CombiningHandlers handlers;
  // The films: their fixed-point sums, added onto rank 0 in steps of kReducePixels.
  const std::size_t pixels = mine.film.sums().size();
  std::vector<Film::Sums> sums(root() ? pixels : 0);
  std::vector<std::uint32_t> counts(root() ? pixels : 0);
  for (std::size_t at = 0; at < pixels; at += kReducePixels) {
    const std::size_t n = std::min(kReducePixels, pixels - at);
    MPI_Reduce(mine.film.sums().data() + at, root() ? sums.data() + at : nullptr, int(n * 6), mpi_->fixedType,
               mpi_->addOp, 0, MPI_COMM_WORLD);
  }
  MPI_Reduce(mine.film.counts().data(), root() ? counts.data() : nullptr, int(pixels), MPI_UINT32_T, MPI_SUM, 0,
             MPI_COMM_WORLD);

  // The totals, on every rank (chapter 9's second image takes the samples the first one got).
  std::uint64_t totals[5] = {mine.rays, mine.badSamples, std::uint64_t(mine.spp), mine.interrupted ? 1u : 0u,
                             mine.cameraRays};
  MPI_Allreduce(MPI_IN_PLACE, totals, 5, MPI_UINT64_T, MPI_SUM, MPI_COMM_WORLD);
  double longest[2] = {mine.seconds, mine.partialPass}; // (a pass cut short on any rank makes the whole one partial)
  MPI_Allreduce(MPI_IN_PLACE, longest, 2, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
  const double seconds = longest[0];

  // The sample indices each rank took, to rank 0 (for a .film's header).
  std::vector<int> ranges;
  for (const SampleRange& r : mine.samples)
    ranges.insert(ranges.end(), {r.first, r.count});
  int length = int(ranges.size());
  const auto ranks = static_cast<std::size_t>(size_);
  std::vector<int> lengths(ranks), offsets(ranks);
  MPI_Gather(&length, 1, MPI_INT, lengths.data(), 1, MPI_INT, 0, MPI_COMM_WORLD);
  for (int r = 1; r < size_; ++r)
    offsets[std::size_t(r)] = offsets[std::size_t(r - 1)] + lengths[std::size_t(r - 1)];
  std::vector<int> everyRange(root() ? std::size_t(offsets.back() + lengths.back()) : 0);
  MPI_Gatherv(ranges.data(), length, MPI_INT, everyRange.data(), lengths.data(), offsets.data(), MPI_INT, 0,
              MPI_COMM_WORLD);

  RenderResult result{root() ? Film(mine.film.width(), mine.film.height(), std::move(sums), std::move(counts))
                             : std::move(mine.film)};
  result.rays = totals[0];
  result.badSamples = totals[1];
  result.spp = int(totals[2]);
  result.meanSpp = double(result.spp);
  result.interrupted = totals[3] > 0;
  result.cameraRays = totals[4];
  result.partialPass = longest[1];
  result.seconds = seconds;
  if (root()) {
    std::vector<SampleRange> sorted;
    for (std::size_t i = 0; i + 1 < everyRange.size(); i += 2)
      sorted.push_back({everyRange[i], everyRange[i + 1]});
    std::sort(sorted.begin(), sorted.end(), [](const SampleRange& a, const SampleRange& b) { return a.first < b.first; });
    result.samples = uniteRanges({}, sorted, "", "the ranks");
  } else {
    result.samples = mine.samples;
  }
  combineSeconds_ = std::chrono::duration<double>(Clock::now() - start).count();
  return result;
}

} // namespace raylife
