// The chapters raylife_check grades, one line each: how, at what size, with how many samples. A new chapter adds
// its line here and renders its golden with tools/update_goldens.sh BUILD CHAPTER (docs/golden-tests.md).
#pragma once

#include <string>

namespace raylife::check {

/// How a chapter's image is graded.
enum class Grading {
  Exact,       ///< Deterministic chapters: every channel within a tolerance of the golden, in the image's domain.
  Statistical, ///< Chapters that sample at random: per-pixel z-test and image-mean test against a reference.
};

/// One chapter's entry.
struct GradedChapter {
  int number;          ///< The chapter's number (raylife_check 4 ...).
  const char* binary;  ///< Its program, and the golden's file name: tests/golden/BINARY.pfm.
  Grading grading;     ///< Exact or Statistical.
  int width;           ///< The golden's render size (--width, --height); Statistical: images k times as large
  int height;          ///< in each direction pass too (the chapter's default size is one of them).
  int spp;             ///< Statistical: the chapter's default samples per pixel, assumed when nothing says.
  int referenceSpp;    ///< Statistical: the reference's samples per pixel (0 for Exact).
  int cell = 1;        ///< Statistical: graded in cells of cell×cell reference pixels (render/grading.h) at the
                       ///< default spp; an image of fewer samples in larger cells (main.cpp, cellsFor).
};

/// The seed of the statistical references: not the chapters' default 0, so that a student's default render
/// shares no samples with its reference.
inline constexpr int kReferenceSeed = 1;

// Exact goldens are 160x120 (a PFM), plus the PNG of the chapter's default render; statistical references are
// 64x48 (a quarter of the Cornell box's 256x192 and a fifth of the Whitted scene's 320x240), cheap at many spp.
// Chapter 5 samples its pixels at random (anti-aliasing), so another seed moves its edges: graded statistically.
// Cells: at its default spp, chapter 7 has pixels whose mean is skewed (paths that find its small lamp only
// through the mirror or the glass: rare, bright samples), and one pixel's z is then far from normal: 80 to 100 of
// 3072 pixels of a correct chapter 7 fail where about 9 should. Graded in cells of 4x4 pixels, which pools 1024
// samples, it fails as often as the bound expects (0 to 3 of 192, over 8 seeds), and a 5% brighter, moved or
// recoloured lamp or wall still fails by far (tests/check/test_check.cpp). Chapter 6 had the same small lamp and
// cells of 2x2 (15 to 25 of 3072 pixels failed); under its large lamp it is graded per pixel: 4 to 14 of 3072 fail
// over 8 seeds (about 9 expected), and its lamp 5% brighter fails 152, moved by 10 units 186.
// Chapter 16 renders smallpt's room, whose lamp is hidden in the ceiling: at 64 spp its rare bright paths (through
// the glass ball, off the mirror) put 38 to 61 of 3072 pixels past the per-pixel bound (22) at six seeds, as
// chapter 8 does there. In cells of 4x4 it fails 0 or 1 of 192 (bound 5), and the lamp 5% brighter fails by its
// image mean (z 11 and 13 at two seeds; tests/check/test_check.cpp).
// Chapter 17 renders the same room on an OpenCL device, in float: graded as chapter 16, against a reference of its
// own (rendered by the opencl build: tools/update_goldens.sh build-opencl step17_opencl), since float moves smallpt's
// huge walls by their rounding. Its program exists only in the opencl build, which is where it is graded.
inline constexpr GradedChapter kGradedChapters[] = {
    {1, "step01_camera", Grading::Exact, 160, 120, 1, 0},
    {2, "step02_sphere", Grading::Exact, 160, 120, 1, 0},
    {3, "step03_lambert", Grading::Exact, 160, 120, 1, 0},
    {4, "step04_shadows", Grading::Exact, 160, 120, 1, 0},
    {5, "step05_whitted", Grading::Statistical, 64, 48, 16, 4096},
    {6, "step06_path_tracer", Grading::Statistical, 64, 48, 128, 16384, 1},
    {7, "step07_light_sampling", Grading::Statistical, 64, 48, 64, 8192, 4},
    {8, "step08_mis", Grading::Statistical, 64, 48, 64, 8192},
    {9, "step09_bvh", Grading::Exact, 160, 120, 1, 0},
    {10, "step10_meshes", Grading::Exact, 160, 120, 1, 0},
    {11, "step11_distributed", Grading::Statistical, 64, 48, 64, 4096, 2},
    {12, "step12_ambient_occlusion", Grading::Statistical, 64, 64, 64, 4096},
    {13, "step13_bdpt", Grading::Statistical, 64, 48, 16, 2048, 2},
    {14, "step14_textures", Grading::Statistical, 64, 48, 16, 4096, 2},
    {15, "step15_volumes", Grading::Statistical, 64, 48, 64, 4096, 4},
    {16, "step16_wavefront", Grading::Statistical, 64, 48, 64, 8192, 4},
    {17, "step17_opencl", Grading::Statistical, 64, 48, 64, 8192, 4},
};

/// The entry of chapter `name` ("4", "04" or "step04_shadows"), or nullptr.
inline const GradedChapter* findChapter(const std::string& name)
{
  for (const GradedChapter& c : kGradedChapters)
    if (name == c.binary || name == std::to_string(c.number) || (name.size() == 2 && name[0] == '0' &&
                                                                  name.substr(1) == std::to_string(c.number)))
      return &c;
  return nullptr;
}

} // namespace raylife::check
