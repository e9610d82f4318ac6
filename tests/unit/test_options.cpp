// The shared command-line parser with a chapter's own options (issue 26, item 4): "--name value" and "--name=value"
// for every option, each kind of value checked, defaults, --help listing them, and malformed declarations refused.
#include "render/options.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <limits>

using namespace raylife;

namespace {

// Options of every kind, as a chapter would declare them.
const std::vector<ChapterOption> kOwn = {
    {.name = "--heuristic", .kind = OptionKind::Choice, .help = "the MIS heuristic", .defaultValue = "power",
     .choices = {"power", "balance"}},
    {.name = "--unweighted", .kind = OptionKind::Flag, .help = "every strategy at weight 1"},
    {.name = "--bounces", .kind = OptionKind::Integer, .help = "bounces", .defaultValue = "3", .min = 0, .max = 64},
    {.name = "--radius", .kind = OptionKind::Number, .help = "a radius", .defaultValue = "0.5", .min = 0, .max = 10},
    {.name = "--strategy", .kind = OptionKind::IntegerList, .help = "s,t", .defaultValue = "1,1", .min = 0,
     .max = 16},
};

RenderOptions parse(std::vector<const char*> args, const std::vector<ChapterOption>& own = kOwn)
{
  args.insert(args.begin(), "step");
  return parseCommandLine(int(args.size()), args.data(), own);
}

} // namespace

TEST_CASE("a chapter's options: defaults, both spellings, every kind of value")
{
  const ChapterOptions none = parse({}).chapter;
  CHECK(none.choice("--heuristic") == "power");
  CHECK_FALSE(none.flag("--unweighted"));
  CHECK(none.integer("--bounces") == 3);
  CHECK(none.number("--radius") == 0.5);
  CHECK(none.integers("--strategy") == std::vector<long long>{1, 1});
  CHECK_FALSE(none.given("--heuristic"));

  for (const auto& args : {std::vector<const char*>{"--heuristic", "balance", "--unweighted", "--bounces", "7",
                                                    "--radius", "2.25", "--strategy", "0,3"},
                           std::vector<const char*>{"--heuristic=balance", "--unweighted", "--bounces=7",
                                                    "--radius=2.25", "--strategy=0,3"}}) {
    const ChapterOptions o = parse(args).chapter;
    CHECK(o.choice("--heuristic") == "balance");
    CHECK(o.flag("--unweighted"));
    CHECK(o.integer("--bounces") == 7);
    CHECK(o.number("--radius") == 2.25);
    CHECK(o.integers("--strategy") == std::vector<long long>{0, 3});
    CHECK(o.given("--heuristic"));
  }
  // The shared options take both spellings too.
  const RenderOptions shared = parse({"--spp=8", "--width=64", "-o", "a.png", "--output=a.pfm"}, {});
  CHECK(*shared.spp == 8);
  CHECK(shared.outputs == std::vector<std::string>{"a.png", "a.pfm"});
  CHECK(shared.width == 64);
  CHECK_THROWS_WITH(parse({"--spp=8", "--time=2"}, {}), "give --spp or --time, not both");
  CHECK(*parse({"--adaptive=0.1"}, {}).adaptive == 0.1);
  CHECK(parse({"-o", "A.PNG", "-o", "b.Pfm"}, {}).outputs == std::vector<std::string>{"A.PNG", "b.Pfm"});
  CHECK_THROWS_WITH(parse({"-o", "a.png", "-o", "b.PNG"}, {}), "-o is given two .png files; one of each format");
}

TEST_CASE("a chapter's options: faults are usage errors that name the option")
{
  CHECK_THROWS_AS(parse({"--heuristic"}), UsageError);
  CHECK_THROWS_WITH(parse({"--heuristic"}), "--heuristic expects a value");
  CHECK_THROWS_WITH(parse({"--heuristic", "max"}), "--heuristic must be power or balance, got 'max'");
  CHECK_THROWS_WITH(parse({"--heuristic="}), "--heuristic must be power or balance, got ''");
  CHECK_THROWS_WITH(parse({"--unweighted=yes"}), "--unweighted takes no value, got '--unweighted=yes'");
  CHECK_THROWS_WITH(parse({"--quiet=1"}), "--quiet takes no value, got '--quiet=1'");
  CHECK_THROWS_WITH(parse({"--bounces", "x"}), "--bounces expects a whole number, got 'x'");
  CHECK_THROWS_WITH(parse({"--bounces", "65"}), "--bounces must lie in [0, 64], got 65");
  CHECK_THROWS_WITH(parse({"--radius", "inf"}), "--radius expects a number, got 'inf'");
  CHECK_THROWS_WITH(parse({"--radius=-1"}), "--radius must lie in [0, 10], got -1");
  CHECK_THROWS_WITH(parse({"--strategy", "1,"}), "--strategy expects whole numbers separated by commas, got '1,'");
  CHECK_THROWS_WITH(parse({"--strategy", "1,17"}), "--strategy must lie in [0, 16], got 17");
  CHECK_THROWS_WITH(parse({"--heuristc", "power"}),
                    "unknown option '--heuristc' (did you mean '--heuristic'?); see --help");
  CHECK_THROWS_WITH(parse({"--sp=4"}), "unknown option '--sp=4' (did you mean '--spp'?); see --help");
  // Without the declaration the option is unknown.
  CHECK_THROWS_WITH(parse({"--heuristic", "power"}, {}), Catch::Contains("unknown option '--heuristic'"));
}

TEST_CASE("a chapter's options: malformed declarations and undeclared reads are the chapter's bug")
{
  auto declared = [](ChapterOption o) { return parse({}, {o}); };
  CHECK_THROWS_AS(declared({.name = "--spp", .kind = OptionKind::Flag}), std::logic_error);
  CHECK_THROWS_AS(declared({.name = "heuristic", .kind = OptionKind::Flag}), std::logic_error);
  CHECK_THROWS_AS(declared({.name = "--a=b", .kind = OptionKind::Flag}), std::logic_error);
  CHECK_THROWS_AS(declared({.name = "--k", .kind = OptionKind::Choice, .defaultValue = "x"}), std::logic_error);
  CHECK_THROWS_AS(declared({.name = "--n", .kind = OptionKind::Integer, .defaultValue = "2", .min = 0, .max = 1}),
                  std::logic_error); // a default outside its own range
  // No default is allowed (chapter 13's --strategy: all strategies unless given), but then the chapter must ask
  // given() before reading it.
  const ChapterOptions none = declared({.name = "--n", .kind = OptionKind::Integer, .min = 0, .max = 1}).chapter;
  CHECK_FALSE(none.given("--n"));
  CHECK_THROWS_AS(none.integer("--n"), std::logic_error);
  CHECK(parse({"--n", "1"}, {{.name = "--n", .kind = OptionKind::Integer, .min = 0, .max = 1}}).chapter.integer("--n") ==
        1);
  // inf only where the range is unbounded above (chapter 12's --ao-distance).
  const ChapterOption distance{.name = "--d", .kind = OptionKind::Number, .defaultValue = "inf", .min = 1e-300,
                               .max = std::numeric_limits<double>::infinity()};
  CHECK(std::isinf(parse({}, {distance}).chapter.number("--d")));
  CHECK(parse({"--d=2.5"}, {distance}).chapter.number("--d") == 2.5);
  CHECK_THROWS_AS(parse({"--d", "0"}, {distance}), UsageError);
  CHECK_THROWS_AS(declared({.name = "--x", .kind = OptionKind::Number, .defaultValue = "inf", .min = 0, .max = 1}),
                  std::logic_error);
  CHECK_THROWS_AS(parse({}, {kOwn[1], kOwn[1]}), std::logic_error);
  const ChapterOptions o = parse({}).chapter;
  CHECK_THROWS_AS(o.flag("--heuristic"), std::logic_error); // declared as a choice
  CHECK_THROWS_AS(o.number("--nothing"), std::logic_error);
}

TEST_CASE("the help text lists every shared option on the usage line and the chapter own ones with defaults")
{
  const std::string text = usageText({"step08_mis", "scenes/mis.json", 64, true, "the camera and glass", kOwn});
  CHECK(text.find("\nreads from a scene: the camera and glass\n") != std::string::npos);
  CHECK(text.rfind("usage: step08_mis [SCENE.json]", 0) == 0); // the usage line comes first
  const std::string usageLines = text.substr(0, text.find("\n\n"));
  for (const char* option : {"-o FILE", "--width W", "--height H", "--spp N", "--time SECONDS", "--samples F:C",
                             "--seed S", "--threads T", "--max-depth D", "--variance FILE", "--stats FILE",
                             "--adaptive E", "--verbose", "--quiet", "--help", "--heuristic power|balance",
                             "--unweighted", "--bounces N", "--radius X", "--strategy N,N,..."})
    CHECK(usageLines.find(option) != std::string::npos);
  CHECK(text.find("--spp N            samples per pixel (default: 64)") != std::string::npos);
  CHECK(text.find("step08_mis's own options:\n  --heuristic power|balance\n") != std::string::npos);
  CHECK(text.find("the MIS heuristic (default: power)") != std::string::npos);
  CHECK(text.find("--bounces N        bounces (default: 3)") != std::string::npos);
  // A chapter that does not sample adaptively says so beside --adaptive.
  CHECK(usageText({"step04_shadows", "s.json", 1, false, "", {}}).find("this one ignores it") != std::string::npos);
  CHECK(usageText({"step04_shadows", "s.json", 1, false, "", {}}).find("own options") == std::string::npos);
  // A chapter that recurses once a bounce says how deep it goes, under --max-depth; the others say nothing of it.
  CHECK(usageText({"step05_whitted", "s.json", 16, false, "", {}, 1000})
            .find("  --max-depth D      longest path, in bounces (chapters that recurse)\n"
                  "                     (at most 1000 here: each bounce is one call deeper on the stack)\n") !=
        std::string::npos);
  CHECK(text.find("at most") == std::string::npos);
}
