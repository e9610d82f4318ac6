#include "render/image_compare.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace raylife {

ImageDifference compareImages(const Image& image, const Image& reference, double tolerance)
{
  ImageDifference d;
  double sumSq = 0, sumRel = 0;
  std::size_t over = 0;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) {
      bool pixelOver = false;
      for (int c = 0; c < 3; ++c) {
        const double a = image.at(x, y, c), b = reference.at(x, y, c);
        // A NaN compares as infinitely different, never as equal.
        const double diff = std::isnan(a) != std::isnan(b) || std::isnan(a) ? std::numeric_limits<double>::infinity()
                                                                            : std::abs(a - b);
        if (diff > d.maxAbs) {
          d.maxAbs = diff;
          d.worstX = x;
          d.worstY = y;
        }
        sumSq += diff * diff;
        sumRel += diff * diff / (b * b + 0.01);
        pixelOver |= diff > tolerance;
      }
      over += pixelOver;
    }
  const double n = double(image.pixels.size());
  const double mse = n > 0 ? sumSq / n : 0;
  d.rmse = std::sqrt(mse);
  d.psnr = mse > 0 ? 10 * std::log10(1 / mse) : std::numeric_limits<double>::infinity();
  d.relativeMse = n > 0 ? sumRel / n : 0;
  d.overTolerance = image.width * image.height > 0 ? double(over) / double(image.width * image.height) : 0;
  return d;
}

Image differenceImage(const Image& image, const Image& reference, double gain)
{
  Image out(image.width, image.height);
  for (std::size_t i = 0; i < out.pixels.size(); ++i)
    out.pixels[i] = float(gain * std::abs(double(image.pixels[i]) - double(reference.pixels[i])));
  return out;
}

ZTestResult zTestImages(const Image& image, const Image& imageVariance, const Image& reference,
                        const Image& referenceVariance, double critical, double floor)
{
  ZTestResult r;
  std::size_t failed = 0;
  double sumZ = 0, sumDiff = 0, sumVar = 0;
  for (std::size_t i = 0; i < image.pixels.size(); ++i) {
    const double diff = double(image.pixels[i]) - double(reference.pixels[i]);
    const double var = double(imageVariance.pixels[i]) + double(referenceVariance.pixels[i]);
    const double z = diff / std::sqrt(var + floor);
    if (!std::isfinite(z)) {
      ++failed; // a NaN or infinity in either image is a failure, never a pass
      continue;
    }
    failed += std::abs(z) > critical;
    sumZ += z;
    sumDiff += diff;
    sumVar += var + floor;
    ++r.channels;
  }
  const double n = double(image.pixels.size());
  r.failedShare = n > 0 ? double(failed) / n : 0;
  r.meanZ = r.channels ? sumZ / double(r.channels) : 0;
  // The mean difference over all channels has variance Σvar / n² (pixels are independent).
  r.totalZ = sumVar > 0 ? sumDiff / std::sqrt(sumVar) : 0;
  return r;
}

} // namespace raylife
