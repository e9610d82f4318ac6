// Chapter 15's building blocks against their formulas: the Henyey–Greenstein phase function (chi-square of its
// sampler, normalisation, mean cosine, the sign of g), free-flight sampling (unbiased per channel for coloured
// media), and the scene keys of media (what the loader accepts, refuses and warns about).
#include "../statistics/chi_square.h"

#include "core/rng.h"
#include "scene/scene.h"
#include "shading/medium.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include <unistd.h>

using namespace raylife;
using namespace raylife::test;

namespace {

constexpr double kSignificance = 0.001;

// ∫ f(μ) dμ over [−1, 1] by Simpson's rule on n (even) intervals, in double.
template <class F> double integrateCosine(F f, int n = 200000)
{
  const double h = 2.0 / n;
  double sum = f(-1.0) + f(1.0);
  for (int i = 1; i < n; ++i)
    sum += (i % 2 ? 4 : 2) * f(-1.0 + i * h);
  return sum * h / 3;
}

// The phase function written out from the page's formula, in double: p = (1 − g²)/(4π (1 + g² − 2g μ)^{3/2}).
double hgFormula(double mu, double g)
{
  return (1 - g * g) / (4 * std::numbers::pi * std::pow(1 + g * g - 2 * g * mu, 1.5));
}

} // namespace

TEST_CASE("HG: the sampler matches its pdf by chi-square for g in {-0.9, -0.3, 0, 0.3, 0.9}")
{
  for (const double g : {-0.9, -0.3, 0.0, 0.3, 0.9}) {
    // Around an oblique direction of travel, so that the frame is exercised too; the test's cells are in the
    // world's (cosθ, φ), where p depends on w·ω' only.
    const Vec3 w = glm::normalize(Vec3(0.3, -0.5, 0.8));
    const ChiSquareResult r = chiSquareTest(
        [&](Vec2 u, Real) { return std::optional<Vec3>(sampleHg(w, Real(g), u).wi); },
        [&](const Vec3& wi) { return double(hgPhase(glm::dot(w, wi), Real(g))); }, 400000, 11, kSignificance, 20,
        40, 4);
    INFO("g = " << g << ": " << r.summary());
    CHECK(r.passed);
  }
}

TEST_CASE("HG: the pdf integrates to 1, its mean cosine is g, and the returned pdf is the phase value")
{
  for (const double g : {-0.9, -0.3, 0.0, 0.3, 0.9}) {
    const double norm = 2 * std::numbers::pi * integrateCosine([g](double mu) { return double(hgPhase(Real(mu), Real(g))); });
    const double mean = 2 * std::numbers::pi * integrateCosine([g](double mu) { return mu * double(hgPhase(Real(mu), Real(g))); });
    INFO("g = " << g << ": integral " << norm << ", mean cosine " << mean);
    CHECK(norm == Approx(1).epsilon(1e-5));
    CHECK(mean == Approx(g).margin(1e-5));
    // The sampler's mean cosine, against the direction of travel: +g (forward for g > 0), within 5 standard errors.
    Sampler rng(7, 0, 0, 3);
    const int n = 200000;
    double sum = 0, sum2 = 0;
    const Vec3 w(0, 0, 1);
    for (int i = 0; i < n; ++i) {
      const PhaseSample s = sampleHg(w, Real(g), Vec2(rng.next1D(), rng.next1D()));
      CHECK_FALSE(std::abs(double(s.pdf) - double(hgPhase(s.wi.z, Real(g)))) > 1e-3 * double(s.pdf));
      sum += double(s.wi.z);
      sum2 += double(s.wi.z) * double(s.wi.z);
    }
    const double m = sum / n, se = std::sqrt((sum2 / n - m * m) / n);
    INFO("sampled mean cosine " << m << " +- " << se);
    CHECK(std::abs(m - g) < 5 * se + 1e-6);
  }
}

TEST_CASE("HG: the sign convention: cosθ is between the directions of travel before and after, g > 0 forward")
{
  // The formula on the page, and the mirrored convention (pbrt-v4's p(ωo·ωi) with ωo = −ω) which must differ.
  for (const double g : {-0.7, 0.4, 0.8})
    for (const double mu : {-1.0, -0.5, 0.0, 0.5, 1.0}) {
      CHECK(double(hgPhase(Real(mu), Real(g))) == Approx(hgFormula(mu, g)).epsilon(1e-5));
      if (mu != 0)
        CHECK(std::abs(double(hgPhase(Real(mu), Real(g))) - hgFormula(-mu, g)) > 1e-3 * hgFormula(mu, g));
    }
  // g = 0.8 sends most light on (cosθ near 1), g = −0.8 back.
  CHECK(hgPhase(Real(1), Real(0.8)) > 100 * hgPhase(Real(-1), Real(0.8)));
  CHECK(hgPhase(Real(-1), Real(-0.8)) > 100 * hgPhase(Real(1), Real(-0.8)));
  CHECK(sampleHgCosTheta(Real(0.5), Real(0)) == Approx(-1));
  CHECK(sampleHgCosTheta(Real(0.5), Real(0.999999)) == Approx(1).margin(1e-4));
}

TEST_CASE("free flight: unbiased per channel for a coloured medium (spectral MIS), with or without a surface")
{
  // E[weight; pass] = e^{−σt tMax} and E[weight; scatter] = σs/σt (1 − e^{−σt tMax}), per channel; also E[t·weight;
  // scatter] against its integral, which a wrong distance distribution would miss.
  const Color sigmaA(Real(0.2), Real(0.05), Real(0));
  const Color sigmaS(Real(0.5), Real(1.5), Real(4));
  for (const Real tMax : {Real(0.7), Real(3), kInfinity}) {
    Sampler rng(3, 0, 0, 9);
    const int n = 400000;
    glm::dvec3 pass(0), scatter(0), scatterT(0), pass2(0), scatter2(0);
    for (int i = 0; i < n; ++i) {
      const FreeFlight f = sampleFreeFlight(sigmaA, sigmaS, tMax, rng.next1D(), rng.next1D());
      REQUIRE(std::isfinite(f.weight.r + f.weight.g + f.weight.b));
      const glm::dvec3 w(f.weight);
      if (f.scattered) {
        scatter += w;
        scatter2 += w * w;
        scatterT += w * double(f.t);
      } else {
        pass += w;
        pass2 += w * w;
      }
    }
    for (int c = 0; c < 3; ++c) {
      const double st = double(sigmaA[c] + sigmaS[c]), ss = double(sigmaS[c]), T = double(tMax);
      const double tr = std::exp(-st * T);
      const double expectPass = tr, expectScatter = ss / st * (1 - tr);
      // ∫₀ᵀ t σs e^{−σt t} dt = σs/σt² (1 − e^{−σt T}(1 + σt T)).
      const double expectT = ss / (st * st) * (1 - (std::isfinite(T) ? tr * (1 + st * T) : 0));
      const double sePass = std::sqrt(pass2[c] / n / n) + 1e-12, seScatter = std::sqrt(scatter2[c] / n / n) + 1e-12;
      INFO("tMax " << tMax << " channel " << c << ": pass " << pass[c] / n << " vs " << expectPass << ", scatter "
                   << scatter[c] / n << " vs " << expectScatter << ", t " << scatterT[c] / n << " vs " << expectT);
      CHECK(std::abs(pass[c] / n - expectPass) < 5 * sePass);
      CHECK(std::abs(scatter[c] / n - expectScatter) < 5 * seScatter);
      CHECK(scatterT[c] / n == Approx(expectT).epsilon(0.02));
    }
  }
}

// ---- The scene keys ----

namespace {

std::string loadError(const std::string& text)
{
  try {
    parseScene(text, "media.json");
  } catch (const SceneError& e) {
    return e.what();
  }
  return "";
}

const std::string kCamera = R"("camera": {"eye": [0, 0, 5], "focal": [0, 0, 0]})";
// A unit cube's 12 triangles, wound outwards; `flip` winds them inwards.
std::string cube(bool flip, const std::string& extra)
{
  const std::string tris = flip ? R"([[0,1,2],[0,2,3],[4,6,5],[4,7,6],[0,5,1],[0,4,5],[3,2,6],[3,6,7],[0,3,7],[0,7,4],[1,5,6],[1,6,2]])"
                                : R"([[0,2,1],[0,3,2],[4,5,6],[4,6,7],[0,1,5],[0,5,4],[3,6,2],[3,7,6],[0,7,3],[0,4,7],[1,6,5],[1,2,6]])";
  return R"({"material": "b", "vertices": [[-1,-1,-1],[1,-1,-1],[1,1,-1],[-1,1,-1],[-1,-1,1],[1,-1,1],[1,1,1],[-1,1,1]], "triangles": )" +
         tris + extra + "}";
}

} // namespace

TEST_CASE("scene keys: media, medium, camera.medium, interior and exterior load as DESIGN.md section 5 says")
{
  const Scene s = parseScene(R"({"camera": {"eye": [0, 0, 5], "focal": [0, 0, 0], "medium": null},
    "media": {"fog": {"sigma_a": 0.1, "sigma_s": [0.2, 0.3, 0.4], "g": -0.5}, "ink": {"sigma_a": 2}},
    "medium": "fog",
    "materials": {"b": {"type": "interface"}, "d": {"type": "diffuse"}},
    "spheres": [{"center": [0, 0, 0], "radius": 1, "material": "b", "interior": "ink"},
                {"center": [3, 0, 0], "radius": 1, "material": "d"}],
    "meshes": [)" + cube(true, R"(, "interior": "ink", "exterior": null)") + "]}",
                             "media.json");
  REQUIRE(s.media.size() == 2);
  CHECK(s.media[0].sigmaA == Color(Real(0.1)));
  CHECK(s.media[0].sigmaS == Color(Real(0.2), Real(0.3), Real(0.4)));
  CHECK(s.media[0].g == Real(-0.5));
  CHECK(s.media[1].sigmaS == Color(0));
  CHECK(s.medium == 0);
  CHECK(s.cameraMedium == kVacuum); // camera.medium null: the camera is in vacuum although the scene is in fog
  CHECK(s.materials[0].type == MaterialType::Interface);
  const MediumInterface ball = s.mediumInterface(0);
  CHECK(ball.changes);
  CHECK(ball.interior == 1);
  CHECK(ball.exterior == 0); // exterior defaults to the top-level medium
  CHECK_FALSE(s.mediumInterface(1).changes);
  // The inward-wound cube's sides are swapped, so that "exterior" is on the side its normals point to.
  const MediumInterface box = s.mediumInterface(2);
  CHECK(box.interior == kVacuum);
  CHECK(box.exterior == 1);
  // Sides by direction: leaving along the normal is outside, against it inside; a shape without media keeps.
  CHECK(ball.after(Vec3(0, 0, 1), Vec3(0, 0.1, 1), 5) == 0);
  CHECK(ball.after(Vec3(0, 0, 1), Vec3(0, 0.1, -1), 5) == 1);
  CHECK(s.mediumInterface(1).after(Vec3(0, 0, 1), Vec3(0, 0, 1), 5) == 5);
}

TEST_CASE("scene keys: faults in media are refused with the place and the reason")
{
  const std::string head = "{" + kCamera + R"(, "materials": {"b": {"type": "interface"}}, )";
  auto ball = [](const std::string& extra) {
    return R"("spheres": [{"center": [0, 0, 0], "radius": 1, "material": "b")" + extra + "}]";
  };
  struct Case {
    std::string text, place, words;
  };
  const Case cases[] = {
      {head + R"("media": {"fog": {"sigma_s": 1, "g": 1}}, )" + ball("") + "}", "/media/fog/g", "strictly between"},
      {head + R"("media": {"fog": {"sigma_a": -1}}, )" + ball("") + "}", "/media/fog/sigma_a", "negative"},
      {head + R"("media": {"fog": {"sigma_a": [1, 2]}}, )" + ball("") + "}", "/media/fog/sigma_a", "[r, g, b]"},
      {head + R"("media": {"fog": {"sigma": 1}}, )" + ball("") + "}", "/media/fog/sigma", "unknown key"},
      {head + R"("media": {"fog": {}}, )" + ball(R"(, "interior": "fgo")") + "}", "/spheres/0/interior",
       "did you mean 'fog'"},
      {head + R"("medium": "air", )" + ball("") + "}", "/medium", "no \"media\""},
      {"{" + kCamera + R"(, "materials": {"b": {"type": "interface", "emission": [1, 1, 1]}}, )" + ball("") + "}",
       "/materials/b/emission", "cannot emit"},
      // An open mesh (a single square) given an interior.
      {"{" + kCamera + R"(, "media": {"fog": {}}, "materials": {"b": {"type": "interface"}}, "meshes": [{"material": "b",
        "vertices": [[0,0,0],[1,0,0],[1,1,0],[0,1,0]], "triangles": [[0,1,2],[0,2,3]], "interior": "fog"}]})",
       "/meshes/0/interior", "open"},
      // A closed cube with one triangle wound the other way.
      {"{" + kCamera + R"(, "media": {"fog": {}}, "materials": {"b": {"type": "interface"}}, "meshes": [{"material": "b",
        "vertices": [[-1,-1,-1],[1,-1,-1],[1,1,-1],[-1,1,-1],[-1,-1,1],[1,-1,1],[1,1,1],[-1,1,1]],
        "triangles": [[0,1,2],[0,3,2],[4,5,6],[4,6,7],[0,1,5],[0,5,4],[3,6,2],[3,7,6],[0,7,3],[0,4,7],[1,6,5],[1,2,6]],
        "interior": "fog"}]})",
       "/meshes/0/interior", "wound"},
  };
  for (const Case& c : cases) {
    const std::string message = loadError(c.text);
    INFO(message);
    CHECK(message.find("media.json:") == 0);
    CHECK(message.find(c.place) != std::string::npos);
    CHECK(message.find(c.words) != std::string::npos);
  }
}

TEST_CASE("scene keys: a camera inside a sphere with an interior while camera.medium says otherwise is warned of")
{
  const std::string scene = R"({"camera": {"eye": [0, 0, 0.5], "focal": [0, 0, 0]}, "media": {"milk": {"sigma_s": 3}},
    "materials": {"g": {"type": "glass"}},
    "spheres": [{"center": [0, 0, 0], "radius": 1, "material": "g", "interior": "milk"}]})";
  const Scene s = parseScene(scene, "media.json");
  REQUIRE(s.warnings.size() == 1);
  INFO(s.warnings[0]);
  CHECK(s.warnings[0].find("/spheres/0") != std::string::npos);
  CHECK(s.warnings[0].find("'milk'") != std::string::npos);
  CHECK(s.warnings[0].find("no medium") != std::string::npos);
  // Said where it is: no warning.
  std::string said = scene;
  const std::string focal = R"("focal": [0, 0, 0]})";
  said.replace(said.find(focal), focal.size(), R"("focal": [0, 0, 0], "medium": "milk"})");
  CHECK(parseScene(said, "media.json").warnings.empty());
}

TEST_CASE("scene keys: a density file's faults are refused, naming the file and the place in it")
{
  const auto dir = std::filesystem::temp_directory_path() / ("raylife15_density_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  auto write = [&](const std::string& name, const std::string& text) { std::ofstream(dir / name) << text; };
  write("short.json", R"({"resolution": [2, 2, 2], "bounds": [[0, 0, 0], [1, 1, 1]], "density": [1, 2, 3]})");
  write("negative.json", R"({"resolution": [1, 1, 2], "bounds": [[0, 0, 0], [1, 1, 1]], "density": [1, -2]})");
  write("flat.json", R"({"resolution": [1, 1, 1], "bounds": [[0, 0, 0], [1, 0, 1]], "density": [1]})");
  write("good.json", R"({"resolution": [1, 1, 2], "bounds": [[0, 0, 0], [1, 1, 1]], "density": [1, 3]})");
  auto scene = [&](const std::string& density, const std::string& sigmaS = "1") {
    return "{" + kCamera + R"(, "media": {"smoke": {"sigma_s": )" + sigmaS + R"(, "density": )" + density + R"(}},
      "materials": {"b": {"type": "interface"}}, "spheres": [{"center": [0, 0, 0], "radius": 1, "material": "b", "interior": "smoke"}]})";
  };
  const std::string sceneName = (dir / "scene.json").string();
  auto error = [&](const std::string& text) {
    try {
      parseScene(text, sceneName);
    } catch (const SceneError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  CHECK(error(scene(R"({"file": "missing.json"})")).find("cannot open the density file 'missing.json'") != std::string::npos);
  CHECK(error(scene(R"({"file": "short.json"})")).find("'short.json' at /density: expected an array of nx*ny*nz = 8") != std::string::npos);
  CHECK(error(scene(R"({"file": "negative.json"})")).find("/density/1: a density must be") != std::string::npos);
  CHECK(error(scene(R"({"file": "flat.json"})")).find("/bounds: the low corner must lie below") != std::string::npos);
  CHECK(error(scene(R"({"file": "good.json", "majorant": "local"})")).find("/media/smoke/density/majorant") != std::string::npos);
  const Scene s = parseScene(scene(R"({"file": "good.json", "majorant": "global"})"), sceneName);
  REQUIRE(s.media[0].density);
  CHECK(s.media[0].globalMajorant);
  CHECK(s.media[0].density->globalMajorant == Real(3));
  CHECK(s.media[0].density->density(Vec3(0.5, 0.5, 0.25)) == Approx(1));  // the first cell's centre
  CHECK(s.media[0].density->density(Vec3(0.5, 0.5, 0.5)) == Approx(2));   // halfway between the two centres
  CHECK(s.media[0].density->density(Vec3(0.5, 0.5, 1.5)) == 0);            // outside the box
  // The majorant grid's resolution: cells along the box's longest side (here z), fewer along the others.
  CHECK(error(scene(R"({"file": "good.json", "majorant_cells": 0})")).find("/media/smoke/density/majorant_cells: must be at least 1") != std::string::npos);
  CHECK(error(scene(R"({"file": "good.json", "majorant_cells": 2.5})")).find("/media/smoke/density/majorant_cells") != std::string::npos);
  // A ray across the box at its densest meets sigma_t x 3 x sqrt(3) tentative collisions, each a step of delta
  // tracking: at most 1e9. Just below, and just above:
  CHECK(parseScene(scene(R"({"file": "good.json"})", "1.9e8"), sceneName).media[0].density);
  const std::string thick = error(scene(R"({"file": "good.json"})", "2e8"));
  CHECK(thick.find("/media/smoke/density: a ray across the density box at its densest would meet 1.04e+09 tentative "
                   "collisions (sigma_t 2e+08 x density 3 x the box's diagonal 1.73)") != std::string::npos);
  // A rate at the edge of the numbers' range, over a box so small that a ray across it meets only 1.7e8 collisions:
  // tracking sums three channels' rates, which would overflow (in the double build; the float build refuses 1e308
  // as it reads it).
  if (sizeof(Real) == 8) {
    write("tiny.json",
          R"({"resolution": [1, 1, 2], "bounds": [[0, 0, 0], [1e-300, 1e-300, 1e-300]], "density": [1, 1]})");
    CHECK(error(scene(R"({"file": "tiny.json"})", "1e308"))
              .find("/media/smoke/density: sigma_t (1e+308, the largest channel of sigma_a + sigma_s) times the "
                    "largest density (1) is beyond the range of the renderer's numbers") != std::string::npos);
    // A box 1e-170 across, whose sides squared underflow to 0: its diagonal is still 1.73e-170, so a rate of 1e180
    // is 1.7e10 collisions across, and refused (CI's fuzzer found a box whose diagonal had come out 0).
    write("speck.json",
          R"({"resolution": [1, 1, 2], "bounds": [[0, 0, 0], [1e-170, 1e-170, 1e-170]], "density": [1, 1]})");
    CHECK(error(scene(R"({"file": "speck.json"})", "1e180"))
              .find("would meet 1.73e+10 tentative collisions (sigma_t 1e+180 x density 1 x the box's diagonal "
                    "1.73e-170)") != std::string::npos);
  }
  const Scene fine = parseScene(scene(R"({"file": "good.json", "majorant_cells": 4})"), sceneName);
  CHECK(fine.media[0].density->mz == 4);
  CHECK(fine.media[0].density->mx == 4); // the box is a cube
  CHECK(fine.media[0].density->majorants.size() == 64);
  std::filesystem::remove_all(dir);
}
