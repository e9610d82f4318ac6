// MPI rendering (issue 24; the MPI build only): mpirun -np N gives the one-process bytes for any N, a time budget
// gives the union of the ranks' samples, and every fault (a bad or different scene on one rank, a failed write, a
// killed rank, Ctrl-C) ends the job with one message from rank 0 and no half-written file.
#include "process.h"

#include "render/film_file.h"
#include "render/image_io.h"

#include <catch2/catch.hpp>

#include <chrono>
#include <csignal>
#include <sstream>
#include <regex>
#include <thread>

using namespace raylife::test;
namespace fs = std::filesystem;

namespace {

const std::string kMpirun = MPIEXEC;
const std::string kScenes = RAYLIFE_SCENES;
const std::string kStep04 = STEP04, kStep06 = STEP06, kStep07 = STEP07, kStep09 = STEP09, kStep13 = STEP13,
                  kStep16 = STEP16;
// Open MPI refuses root unless told (CI runs as root).
const std::vector<std::string> kEnv = {"OMPI_ALLOW_RUN_AS_ROOT=1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1"};

// mpirun -q (no banners of its own) --oversubscribe (3 ranks on 2 cores) -np N, then `command`.
std::vector<std::string> mpi(int ranks, std::vector<std::string> command)
{
  std::vector<std::string> args = {"-q", "--oversubscribe", "-np", std::to_string(ranks)};
  args.insert(args.end(), command.begin(), command.end());
  return args;
}

std::vector<std::string> small(const std::string& scene, std::vector<std::string> extra)
{
  std::vector<std::string> args = {kScenes + "/" + scene, "--width", "40", "--height", "30", "--seed", "3", "--quiet"};
  args.insert(args.end(), extra.begin(), extra.end());
  return args;
}

// A .film file's exact sums: what follows its header (the header's seconds differ from run to run).
std::string sums(const fs::path& film)
{
  const std::string bytes = readFile(film);
  const std::size_t end = bytes.find("\nend\n");
  REQUIRE(end != std::string::npos);
  return bytes.substr(end + 5);
}

std::vector<std::string> with(const std::string& binary, std::vector<std::string> args)
{
  args.insert(args.begin(), binary);
  return args;
}

} // namespace

TEST_CASE("mpirun -np 2 and 3 give the one-process bytes for chapters 4 - 6 - 7 - 9 - 13 (splats) and 16 (wavefronts)")
{
  struct Case {
    std::string binary, scene, spp;
  };
  for (const Case& c : {Case{kStep04, "spheres.json", "3"}, Case{kStep06, "cornell.json", "23"},
                        Case{kStep07, "cornell.json", "16"}, Case{kStep09, "cornell.json", "5"},
                        Case{kStep13, "caustics.json", "5"}, Case{kStep16, "smallpt.json", "7"}}) {
    INFO(c.binary);
    const TempDir dir;
    const auto args = small(c.scene, {"--spp", c.spp});
    auto outputs = [&](const std::string& stem) {
      std::vector<std::string> a = args;
      a.insert(a.end(), {"-o", stem + ".pfm", "-o", stem + ".png", "-o", stem + ".film", "--variance", stem + "_var.pfm"});
      return a;
    };
    const Outcome one = run(c.binary, outputs("one"), dir.path(), kEnv); // a singleton: one rank, no mpirun
    INFO(one.err);
    REQUIRE(one.status == 0);
    for (const int ranks : {2, 3}) {
      const std::string stem = "np" + std::to_string(ranks);
      std::vector<std::string> a = outputs(stem);
      if (ranks == 2)
        a.insert(a.end(), {"--threads", "1"});
      const Outcome o = run(kMpirun, mpi(ranks, with(c.binary, a)), dir.path(), kEnv);
      INFO(ranks << " ranks: " << o.err);
      REQUIRE(o.status == 0);
      CHECK(o.err.empty()); // --quiet on every rank, and nothing else said
      for (const std::string suffix : {".pfm", ".png", "_var.pfm"})
        CHECK(readFile(dir.path() / (stem + suffix)) == readFile(dir.path() / ("one" + suffix)));
      // The sums themselves, bit for bit (a float image could hide a difference in the sums' last bits).
      CHECK(sums(dir.path() / (stem + ".film")) == sums(dir.path() / "one.film"));
    }
  }
}

TEST_CASE("MPI ranks and job arrays compose: a .film of 2 ranks merges with another job's into the same bytes")
{
  const TempDir dir;
  const auto args = small("cornell.json", {"--spp", "20"});
  std::vector<std::string> whole = args;
  whole.insert(whole.end(), {"-o", "one.pfm"});
  REQUIRE(run(kStep06, whole, dir.path(), kEnv).status == 0);
  std::vector<std::string> first = args, second = args;
  first.insert(first.end(), {"--samples", "0:13", "-o", "a.film"});
  second.insert(second.end(), {"--samples", "13:7", "-o", "b.film"});
  REQUIRE(run(kMpirun, mpi(2, with(kStep06, first)), dir.path(), kEnv).status == 0);
  REQUIRE(run(kStep06, second, dir.path(), kEnv).status == 0);
  const raylife::PartialFilm a = raylife::readFilm((dir.path() / "a.film").string());
  CHECK(a.header.samples == std::vector<raylife::SampleRange>{{0, 13}});
  raylife::PartialFilm total = a;
  raylife::mergeFilm(total, "a.film", raylife::readFilm((dir.path() / "b.film").string()), "b.film");
  const std::vector<unsigned char> merged = raylife::encodePfm(total.film.mean());
  CHECK(std::string(merged.begin(), merged.end()) == readFile(dir.path() / "one.pfm"));
}

TEST_CASE("a time budget under MPI writes the union of the ranks' samples and says the total spp")
{
  const TempDir dir;
  const Outcome o = run(kMpirun,
                        mpi(2, with(kStep06, small("cornell.json", {"--time", "1", "--threads", "1", "-o", "t.pfm",
                                                                    "-o", "t.film", "--stats", "s.json"}))),
                        dir.path(), kEnv);
  INFO(o.err);
  REQUIRE(o.status == 0);
  const std::string stats = readFile(dir.path() / "s.json");
  std::smatch m;
  REQUIRE(std::regex_search(stats, m, std::regex(R"("spp": (\d+), "seconds": ([0-9.]+))")));
  const int spp = std::stoi(m[1]);
  CHECK(spp >= 2);
  CHECK(std::stod(m[2]) < 3.0); // every rank stopped at its budget (with a pass to finish)
  CHECK(stats.find("\"ranks\": 2") != std::string::npos);
  const raylife::PartialFilm film = raylife::readFilm((dir.path() / "t.film").string());
  CHECK(film.header.spp == 0); // a time budget: no fixed total
  CHECK(film.header.sampleCount() == spp);
  // Both ranks' blocks of 16 are there: rank 1 took indices from 16 on.
  CHECK(film.header.samples.front().first == 0);
  CHECK(film.header.samples.back().end() > 16);
  for (int y = 0; y < 30; ++y)
    for (int x = 0; x < 40; ++x)
      REQUIRE(film.film.samples(x, y) == std::uint32_t(spp));
  const raylife::Image image = raylife::readPfm((dir.path() / "t.pfm").string());
  CHECK(image.pixels == film.film.mean().pixels);
}

TEST_CASE("a bad or different scene on one rank ends the job with one message from rank 0 and nothing written")
{
  const TempDir dir;
  const std::string good = readFile(kScenes + "/cornell.json");
  writeFile(dir.path() / "good.json", good);
  writeFile(dir.path() / "bad.json", good.substr(0, good.size() / 2));
  writeFile(dir.path() / "other.json", " " + good); // the same scene, other bytes
  const std::vector<std::string> scenes = entries(dir.path());
  auto job = [&](const std::string& second) {
    return std::vector<std::string>{"-q", "-np", "1", kStep06, "good.json", "--spp", "2", "-o", "x.png", ":",
                                    "-np", "1", kStep06, second, "--spp", "2", "-o", "x.png"};
  };
  const Outcome bad = run(kMpirun, job("bad.json"), dir.path(), kEnv);
  CHECK(bad.status == 1);
  CHECK(std::regex_match(bad.err, std::regex("step06_path_tracer: bad\\.json:[0-9]+:[0-9]+: malformed JSON[^\n]+ \\(on rank 1\\)\n")));
  CHECK(entries(dir.path()) == scenes);

  const Outcome differs = run(kMpirun, job("other.json"), dir.path(), kEnv);
  CHECK(differs.status == 1);
  CHECK(differs.err == "step06_path_tracer: the scene file differs between ranks: rank 1 read other bytes than rank "
                       "0 (every rank must render the same scene: copy the same file to every machine)\n");
  CHECK(entries(dir.path()) == scenes);

  const Outcome usage =
      run(kMpirun, mpi(2, with(kStep06, {"good.json", "--spp", "32", "--adaptive", "0.1", "-o", "x.png"})), dir.path(),
          kEnv);
  CHECK(usage.status == 2);
  CHECK(usage.err == "step06_path_tracer: --adaptive needs every sample of a pixel in one process; it cannot be "
                     "split over 2 ranks\n");
  CHECK(entries(dir.path()) == scenes);
}

TEST_CASE("a failed write on rank 0 and a killed rank end the job with one message and nothing written")
{
  const TempDir dir;
  const auto args = small("cornell.json", {"--spp", "4", "-o", "x.png", "-o", "x.pfm"});
  std::vector<std::string> env = kEnv;
  env.push_back("RAYLIFE_FAIL_WRITE_AFTER=100"); // every write fails after 100 bytes, as a full disk would
  std::vector<std::string> full = {"-x", "RAYLIFE_FAIL_WRITE_AFTER"};
  const std::vector<std::string> job = mpi(2, with(kStep06, args));
  full.insert(full.end(), job.begin(), job.end());
  const Outcome write = run(kMpirun, full, dir.path(), env);
  CHECK(write.status == 1);
  CHECK(write.err == "step06_path_tracer: cannot write x.png: No space left on device; nothing was written\n");
  CHECK(entries(dir.path()).empty());

  env = kEnv;
  env.push_back("RAYLIFE_TEST_KILL_RANK=1"); // rank 1 kills itself (SIGKILL) before the films are combined
  std::vector<std::string> killed = {"-x", "RAYLIFE_TEST_KILL_RANK"};
  killed.insert(killed.end(), job.begin(), job.end());
  const Outcome kill = run(kMpirun, killed, dir.path(), env);
  CHECK(kill.status != 0);
  CHECK(kill.err == "step06_path_tracer: the job was stopped while rank 0 waited for the other ranks (a rank died, "
                    "or mpirun was interrupted); nothing was written\n");
  CHECK(entries(dir.path()).empty());
}

TEST_CASE("Ctrl-C on mpirun writes the image so far or nothing - never a torn or temporary file")
{
  const TempDir dir, capture;
  const Child child = start(kMpirun, mpi(2, with(kStep06, small("cornell.json", {"--time", "60", "-o", "x.png"}))),
                            dir.path(), capture.path(), kEnv);
  // Wait until both ranks run and catch SIGTERM (mpirun forwards Ctrl-C to them as SIGTERM).
  const auto start = std::chrono::steady_clock::now();
  std::vector<pid_t> ranks;
  while (ranks.size() < 2 && std::chrono::steady_clock::now() - start < std::chrono::seconds(60)) {
    ranks.clear();
    for (const auto& entry : fs::directory_iterator("/proc")) {
      const std::string pid = entry.path().filename().string();
      if (pid.find_first_not_of("0123456789") != std::string::npos)
        continue;
      const std::string stat = readFile(entry.path() / "stat");
      const std::size_t close = stat.rfind(')');
      if (stat.find("(step06_path_tra") == std::string::npos || close == std::string::npos)
        continue;
      std::istringstream rest(stat.substr(close + 2));
      std::string state;
      pid_t parent = 0;
      rest >> state >> parent;
      if (parent == child.pid && catchesSignal(std::stoi(pid), SIGTERM))
        ranks.push_back(std::stoi(pid));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  REQUIRE(ranks.size() == 2);
  std::this_thread::sleep_for(std::chrono::milliseconds(700)); // a few passes in
  REQUIRE(::kill(child.pid, SIGINT) == 0);
  const Outcome o = wait(child);
  INFO(o.err);
  CHECK(std::chrono::steady_clock::now() - start < std::chrono::seconds(30));
  const std::vector<std::string> left = entries(dir.path());
  // Either the whole image so far (mpirun gave the ranks the second they needed) or nothing at all.
  CHECK((left.empty() || left == std::vector<std::string>{"x.png"}));
  if (!left.empty()) {
    const raylife::Image image = raylife::readPng((dir.path() / "x.png").string());
    CHECK(image.width == 40);
    CHECK(image.height == 30);
  }
}
