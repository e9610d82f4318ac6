// Chapter 1 — spawn a ray from the camera.
//
// Every ray starts at the eye. The camera builds the lecture's orthonormal basis from eye, focal point and up
// (w = (eye − focal)/|eye − focal|, u = (up × w)/|up × w|, v = w × u) and sends the ray through pixel (x, y)
// along d = u·x + v·y − w·z (common/scene/camera.cpp, Camera::ray). This chapter traces nothing yet: it paints each
// pixel with its ray's direction so you can see the basis at work.
#include "render/runner.h"

using namespace raylife;

/// [trace]
// A unit direction has components in [−1, 1]; (d + 1)/2 maps them into [0, 1] so they can be seen as colour:
// red grows to the right (+u), green upwards (+v), and blue towards the viewer (+w).
Color trace(const Scene& /*scene*/, const Ray& ray, Sampler& /*sampler*/)
{
  return (ray.direction + Real(1)) / Real(2);
}
/// [trace]

int main(int argc, char** argv)
{
  const ChapterInfo chapter{.binary = "step01_camera", .defaultScene = "spheres.json", .uses = 0};
  return runChapter(argc, argv, chapter, trace);
}
