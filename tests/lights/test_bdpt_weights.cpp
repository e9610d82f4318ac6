// Chapter 13's MIS weights on single paths: for random paths of 3 edges in a closed diffuse room (eye -> z1 -> z2 ->
// a point y0 on a lamp), the weights the chapter's own functions give the four strategies that make such a path,
// (0,4), (1,3), (2,2) and (3,1), must sum to one; and for paths through a mirror (eye -> z1 -> mirror -> lamp), those
// of the two strategies that can make them. The chapter's main.cpp is compiled here (its main renamed), and each
// weight is read back from the contribution its function returns, divided by what the weight multiplies.
#define main step13Main
#include "../../steps/13_bdpt/main.cpp"
#undef main

#include <catch2/catch.hpp>

namespace {

// The room: the inside of a diffuse sphere of radius 10, a small lamp, the eye at the centre.
Scene room()
{
  return parseScene(R"({ "camera": { "eye": [0, 0, 0], "focal": [0, 0, -1], "vfov": 60, "width": 64, "height": 48 },
                         "materials": { "wall": { "type": "diffuse", "color": [0.7, 0.7, 0.7] },
                                        "lamp": { "type": "diffuse", "color": [0, 0, 0], "emission": [5, 5, 5] } },
                         "spheres": [ { "center": [0, 0, 0], "radius": 10, "material": "wall" },
                                      { "center": [3, 5, -4], "radius": 1, "material": "lamp" } ] })",
                    "room.json");
}

// A BSDF sample record for the diffuse direction wi (local) from wo, as bsdfSample would have made it.
BsdfSample diffuseSample(const Material& m, const Vec3& wo, const Vec3& wi)
{
  return BsdfSample{wi, bsdfEval(m, wo, wi), bsdfPdf(m, wo, wi), false};
}

Vec3 unit(const Vec3& v) { return v / glm::length(v); }

// A point uniform on the camera's film. Its two numbers are drawn one statement at a time, never two in one call: C++
// leaves the order of a call's arguments unspecified (GCC evaluates them right to left, clang left to right), and the
// paths must not depend on the compiler. Here, and for the BSDF samples below, the statements draw in the order GCC
// did when the draws were arguments of one call (the last argument first), so the tests keep their paths.
Vec2 filmPoint(Sampler& sampler, const Camera& camera)
{
  const Real y = sampler.next1D();
  const Real x = sampler.next1D();
  return Vec2(x * Real(camera.width()), y * Real(camera.height()));
}

// The start of both tests' camera subpaths: a primary ray through a random film point that meets the wall at z1, and
// a cosine-weighted bounce from z1 on the side the ray came from. Nothing when the primary ray misses the wall.
struct CameraStart {
  Ray primary;
  Hit z1;
  Frame f1;
  Vec3 wo1, wi1; // local to f1
  Ray bounce;
};

std::optional<CameraStart> cameraStart(const Scene& scene, const Camera& camera, Sampler& sampler)
{
  const Vec2 film = filmPoint(sampler, camera);
  const Ray primary = camera.ray(film);
  const std::optional<Hit> z1 = scene.intersect(primary);
  if (!z1 || z1->primitive != 0)
    return std::nullopt;
  const Frame f1 = Frame::fromNormal(z1->normal);
  const Vec3 wo1 = f1.toLocal(-primary.direction);
  const Vec3 wi1 = sampleCosineHemisphere(sampler.next2D()) * (wo1.z < 0 ? Real(-1) : Real(1));
  return CameraStart{primary, *z1, f1, wo1, wi1, spawnRay(*z1, f1.toWorld(wi1))};
}

// The camera subpath's running sums at z1, as the chapter starts them.
SubpathState stateAtZ1(const Context& c, const Camera& camera, const CameraStart& start)
{
  SubpathState at;
  at.dVCM = mis(c.lightPaths / primaryRayPdf(camera, -glm::dot(camera.basis().w, start.primary.direction)));
  arrive(at, start.z1.t, std::abs(glm::dot(start.z1.normal, start.primary.direction)));
  return at;
}

// The weight of strategy (s,1), read back from the splat that connectToCamera left at z1's pixel: the splat divided
// by what the weight multiplies there (the wall's BSDF from the eye to `towardsPrevious`, the light subpath's
// direction at z1, over the camera's pdf in area measure per light path).
double splatWeight(const Context& c, SplatSums& sums, const Camera& camera, const CameraStart& start,
                   const Material& wall, const Vec3& towardsPrevious)
{
  const Hit& z1 = start.z1;
  const std::optional<Vec2> pixel = camera.project(z1.point);
  REQUIRE(pixel);
  const Color splat = sums.take(std::size_t(int(pixel->y)) * std::size_t(camera.width()) + std::size_t(int(pixel->x)));
  const Vec3 toCamera = camera.eye() - z1.point;
  const Vec3 toEye = unit(toCamera);
  const Real cameraPdfA = primaryRayPdf(camera, glm::dot(camera.basis().w, toEye)) *
                          std::abs(glm::dot(z1.normal, toEye)) / glm::dot(toCamera, toCamera);
  return splat.r /
         (bsdfEval(wall, start.f1.toLocal(toEye), start.f1.toLocal(towardsPrevious)).r * cameraPdfA / c.lightPaths);
}

} // namespace

TEST_CASE("the MIS weights of the strategies that make a path sum to one (random paths of 3 edges)")
{
  const Scene scene = room();
  const Camera camera = scene.makeCamera();
  const LightSampler lights(scene);
  const Strategies strategies;
  SplatSums sums(camera.width(), camera.height());
  Splats splats(camera, sums);
  const Material& wall = scene.materials[0];
  int checked = 0;
  double worst = 0;
  for (std::uint64_t trial = 0; trial < 400; ++trial) {
    Sampler sampler(7, 1, 2, trial);
    const Context c{scene, lights, strategies, splats, sampler, INT_MAX, Real(camera.width() * camera.height())};
    // The camera subpath: a primary ray, z1 on the wall, a diffuse bounce to z2 on the wall.
    const std::optional<CameraStart> start = cameraStart(scene, camera, sampler);
    if (!start)
      continue;
    const Hit* z1 = &start->z1;
    const Frame& f1 = start->f1;
    const Vec3 wo1 = start->wo1, wi1 = start->wi1;
    const Ray& bounce = start->bounce;
    const std::optional<Hit> z2 = scene.intersect(bounce);
    if (!z2 || z2->primitive != 0)
      continue;
    const Frame f2 = Frame::fromNormal(z2->normal);
    const Vec3 wo2 = f2.toLocal(-bounce.direction);

    SubpathState atZ1 = stateAtZ1(c, camera, *start);
    SubpathState atZ2 = atZ1;
    leave(atZ2, diffuseSample(wall, wo1, wi1), bsdfPdf(wall, wi1, wo1));
    arrive(atZ2, z2->t, std::abs(glm::dot(z2->normal, bounce.direction)));
    atZ2.beta = Color(1);

    // (1,3): next-event estimation at z2 picks y0; the same draws give the sample here.
    Sampler replay = sampler;
    const Real uLight = replay.next1D();
    const Vec2 uDirection = replay.next2D();
    const std::optional<LightSample> ls = lights.sample(z2->point, uLight, uDirection);
    const Color nee = connectToLight(c, atZ2, *z2, f2, wo2, 3);
    if (!ls || nee.r <= 0)
      continue;
    const Ray toLight = spawnRay(*z2, ls->wi);
    const std::optional<Hit> y0 = scene.intersect(toLight);
    REQUIRE(y0);
    REQUIRE(y0->primitive == 1);
    const Vec3 wiLight = f2.toLocal(ls->wi);
    const double w13 = nee.r / (bsdfEval(wall, wo2, wiLight).r * std::abs(wiLight.z) * ls->Li.r / ls->pdf);

    // (0,4): the camera subpath goes on from z2 to y0 and hits the lamp there.
    const Real cosY0 = std::abs(glm::dot(y0->normal, ls->wi));
    SubpathState atY0 = atZ2;
    leave(atY0, diffuseSample(wall, wo2, wiLight), bsdfPdf(wall, wiLight, wo2));
    arrive(atY0, y0->t, cosY0);
    const double w04 = weightHitLight(c, atY0, *y0, z2->point, cosY0);

    // (2,2): the light subpath y0 -> y1 = z2, joined to the camera vertex z1. Its start as traceLightSubpath makes it.
    const Vec3 down = -ls->wi; // from y0 towards z2
    const Real emission = emissionPdf(c, 1, y0->point, down);
    const Real cosZ2 = std::abs(glm::dot(z2->normal, down));
    LightVertex y1{*z2, ls->wi, SubpathState{}, 2};
    y1.state.dVC = mis(cosY0 / emission) / mis(cosZ2);
    y1.state.dVCM = mis(lights.pdf(z2->point, 1, y0->point) * cosY0 / (emission * cosZ2));
    atZ1.beta = Color(1);
    const Color joined = connectVertices(c, atZ1, *z1, f1, wo1, y1, 2);
    const Vec3 d12 = z2->point - z1->point;
    const Real r2 = glm::dot(d12, d12);
    const Vec3 wiZ1 = f1.toLocal(unit(d12));
    const Vec3 woZ2 = f2.toLocal(unit(-d12)), wiZ2 = f2.toLocal(ls->wi);
    const double geometry = std::abs(wiZ1.z) * std::abs(woZ2.z) / r2;
    const double w22 = joined.r / (bsdfEval(wall, wo1, wiZ1).r * bsdfEval(wall, woZ2, wiZ2).r * geometry);

    // (3,1): the light subpath goes on from z2 to z1, which is joined to the eye (a splat).
    LightVertex y2{*z1, unit(d12), y1.state, 3};
    leave(y2.state, diffuseSample(wall, wiZ2, woZ2), bsdfPdf(wall, woZ2, wiZ2));
    arrive(y2.state, std::sqrt(r2), std::abs(wiZ1.z));
    y2.state.beta = Color(1);
    connectToCamera(c, y2);
    const double w31 = splatWeight(c, sums, camera, *start, wall, unit(d12));

    const double sum = w04 + w13 + w22 + w31;
    INFO("trial " << trial << ": " << w04 << " + " << w13 << " + " << w22 << " + " << w31);
    CHECK(sum == Approx(1).epsilon(1e-6));
    CHECK(std::min({w04, w13, w22, w31}) > 0);
    worst = std::max(worst, std::abs(sum - 1));
    ++checked;
  }
  std::cout << "MIS weights of " << checked << " paths of 3 edges: largest |sum - 1| = " << worst << "\n";
  CHECK(checked >= 50);
}

TEST_CASE("the MIS weights sum to one on paths through a mirror (a delta vertex: two strategies make them)")
{
  // eye -> z1 on the wall -> m on a mirror ball -> y0 on the lamp. Neither next-event estimation at the mirror nor a
  // connection to it can make this path: only the camera subpath hitting the lamp, (0,4), and the light subpath
  // y0 -> m -> z1 joined to the eye, (3,1). Their weights, read back as above, must sum to one: the running sums
  // must carry a delta vertex's cosines and nothing else (set dVC to 0 there, or drop its cosine, and they do not).
  const Scene scene = parseScene(
      R"({ "camera": { "eye": [0, 0, 0], "focal": [0, 0, -1], "vfov": 60, "width": 64, "height": 48 },
           "materials": { "wall": { "type": "diffuse", "color": [0.7, 0.7, 0.7] },
                          "lamp": { "type": "diffuse", "color": [0, 0, 0], "emission": [5, 5, 5] },
                          "steel": { "type": "mirror", "color": [0.9, 0.9, 0.9] } },
           "spheres": [ { "center": [0, 0, 0], "radius": 10, "material": "wall" },
                        { "center": [3, 5, -4], "radius": 1.5, "material": "lamp" },
                        { "center": [-2, 1, -5], "radius": 3, "material": "steel" } ] })",
      "mirror_room.json");
  const Camera camera = scene.makeCamera();
  const LightSampler lights(scene);
  const Strategies strategies;
  SplatSums sums(camera.width(), camera.height());
  Splats splats(camera, sums);
  const Material& wall = scene.materials[0];
  const Material& steel = scene.materials[2];
  int checked = 0;
  double worst = 0;
  for (std::uint64_t trial = 0; trial < 200000 && checked < 200; ++trial) {
    Sampler sampler(11, 3, 4, trial);
    const Context c{scene, lights, strategies, splats, sampler, INT_MAX, Real(camera.width() * camera.height())};
    // The camera subpath: z1 on the wall, a diffuse bounce that meets the mirror at m, its reflection the lamp at y0.
    const std::optional<CameraStart> start = cameraStart(scene, camera, sampler);
    if (!start)
      continue;
    const Hit* z1 = &start->z1;
    const Vec3 wo1 = start->wo1, wi1 = start->wi1;
    const Ray& toMirror = start->bounce;
    const std::optional<Hit> m = scene.intersect(toMirror);
    if (!m || m->primitive != 2)
      continue;
    const Frame fm = Frame::fromNormal(m->normal);
    const Vec3 woM = fm.toLocal(-toMirror.direction);
    const Real uChoiceM = sampler.next1D();
    const Vec2 uM = sampler.next2D();
    const std::optional<BsdfSample> reflect = bsdfSample(steel, woM, uM, uChoiceM);
    REQUIRE(reflect);
    REQUIRE(reflect->specular);
    const Ray toLamp = spawnRay(*m, fm.toWorld(reflect->wi));
    const std::optional<Hit> y0 = scene.intersect(toLamp);
    if (!y0 || y0->primitive != 1)
      continue;

    // (0,4): the camera subpath's running sums through z1 and the mirror, then the lamp hit.
    SubpathState camera4 = stateAtZ1(c, camera, *start);
    leave(camera4, diffuseSample(wall, wo1, wi1), bsdfPdf(wall, wi1, wo1));
    arrive(camera4, m->t, std::abs(woM.z));
    leave(camera4, *reflect, reflect->pdf);
    const Real cosY0 = std::abs(glm::dot(y0->normal, toLamp.direction));
    arrive(camera4, y0->t, cosY0);
    const double w04 = weightHitLight(c, camera4, *y0, m->point, cosY0);

    // (3,1): the light subpath y0 -> m -> z1 as traceLightSubpath makes it, z1 joined to the eye.
    const Vec3 fromLamp = -toLamp.direction;
    const Real emission = emissionPdf(c, 1, y0->point, fromLamp);
    const Real cosM = std::abs(glm::dot(m->normal, fromLamp));
    SubpathState light;
    light.dVC = mis(cosY0 / emission) / mis(cosM);
    light.dVCM = mis(lights.pdf(m->point, 1, y0->point) * cosY0 / (emission * cosM));
    const Vec3 woLight = fm.toLocal(-fromLamp); // towards the lamp, where the light path came from
    const Real uChoiceBack = sampler.next1D();
    const Vec2 uBack = sampler.next2D();
    const std::optional<BsdfSample> back = bsdfSample(steel, woLight, uBack, uChoiceBack);
    REQUIRE(back);
    leave(light, *back, back->pdf);
    const Vec3 towardsZ1 = fm.toWorld(back->wi);
    REQUIRE(glm::dot(towardsZ1, -toMirror.direction) == Approx(1).margin(1e-9)); // the mirror sends it back to z1
    arrive(light, m->t, std::abs(glm::dot(z1->normal, towardsZ1)));
    light.beta = Color(1);
    LightVertex y2{*z1, unit(m->point - z1->point), light, 3};
    connectToCamera(c, y2);
    const double w31 = splatWeight(c, sums, camera, *start, wall, y2.toPrevious);

    INFO("trial " << trial << ": " << w04 << " + " << w31);
    CHECK(w04 + w31 == Approx(1).epsilon(1e-6));
    CHECK(std::min(w04, w31) > 0);
    worst = std::max(worst, std::abs(w04 + w31 - 1));
    ++checked;
  }
  std::cout << "MIS weights of " << checked << " paths through a mirror: largest |sum - 1| = " << worst << "\n";
  CHECK(checked >= 50);
}
