// gen_sky: a clear daylight sky as an equirectangular environment map (chapter 14), from the analytic model of
// Preetham, Shirley and Smits, "A Practical Analytic Model for Daylight" (SIGGRAPH 1999), with the coefficients the
// paper publishes (its appendix A.2: the Perez distribution's A–E for Y, x, y as linear functions of turbidity T,
// and the zenith luminance and chromaticity).
//
//   gen_sky OUT.exr|OUT.pfm [--elevation DEG] [--azimuth DEG] [--turbidity T] [--width W] [--sun-ratio R]
//
// The sky: luminance and chromaticity (Y, x, y) in each direction from Perez's formula
//   F(θ, γ) = (1 + A e^(B / cos θ)) (1 + C e^(D γ) + E cos² γ),   Y = Y_zenith F(θ, γ) / F(0, θs)
// (θ the direction's zenith angle, γ its angle to the sun, θs the sun's zenith angle), likewise x and y; then
// xyY → XYZ → linear sRGB. Y is in the paper's kcd/m²; the map stores it divided by 10 (a radiance of about 0.1 to
// 1 for the sky), and below the horizon the ground's radiance (a grey of albedo 0.3 lit by the sky and sun:
// albedo × E_horizontal / π).
// The sun: the paper computes its spectral radiance through the atmosphere; this tool does not. It draws the sun
// as a disc (the real 0.27° radius, widened to a texel and a half where the map is coarser) in the sky's colour
// towards it, as bright as makes its irradiance on a surface facing it `sun-ratio` times the sky's on a horizontal
// surface (default 5, a clear day's typical ratio). Say so wherever the map is used as a measurement.
// Directions follow the scene format's convention: u = ½ + atan2(d.x, −d.z)/(2π), v = acos(d.y)/π, so azimuth 0 is
// −z (the map's centre column) and azimuth 90 is +x.
#include "render/image_io.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <numbers>
#include <string>

using namespace raylife;

namespace {

constexpr double kPiD = std::numbers::pi;

struct Perez {
  double A, B, C, D, E;
  double operator()(double cosTheta, double gamma) const
  {
    return (1 + A * std::exp(B / std::max(cosTheta, 1e-3))) *
           (1 + C * std::exp(D * gamma) + E * std::cos(gamma) * std::cos(gamma));
  }
};

// [preetham]
struct SkyModel {
  Perez Y, x, y;
  double zenithY, zenithX, zenithYc; // luminance (kcd/m²) and chromaticity at the zenith
  double thetaS;                     // the sun's zenith angle

  SkyModel(double T, double thetaSun) : thetaS(thetaSun)
  {
    // Appendix A.2: the distribution coefficients.
    Y = {0.1787 * T - 1.4630, -0.3554 * T + 0.4275, -0.0227 * T + 5.3251, 0.1206 * T - 2.5771, -0.0670 * T + 0.3703};
    x = {-0.0193 * T - 0.2592, -0.0665 * T + 0.0008, -0.0004 * T + 0.2125, -0.0641 * T - 0.8989, -0.0033 * T + 0.0452};
    y = {-0.0167 * T - 0.2608, -0.0950 * T + 0.0092, -0.0079 * T + 0.2102, -0.0441 * T - 1.6537, -0.0109 * T + 0.0529};
    // The zenith luminance and chromaticity.
    const double chi = (4.0 / 9.0 - T / 120.0) * (kPiD - 2 * thetaS);
    zenithY = (4.0453 * T - 4.9710) * std::tan(chi) - 0.2155 * T + 2.4192;
    const double t1 = thetaS, t2 = t1 * t1, t3 = t2 * t1, T2 = T * T;
    zenithX = T2 * (0.00166 * t3 - 0.00375 * t2 + 0.00209 * t1) +
              T * (-0.02903 * t3 + 0.06377 * t2 - 0.03202 * t1 + 0.00394) +
              (0.11693 * t3 - 0.21196 * t2 + 0.06052 * t1 + 0.25886);
    zenithYc = T2 * (0.00275 * t3 - 0.00610 * t2 + 0.00317 * t1) +
               T * (-0.04214 * t3 + 0.08970 * t2 - 0.04153 * t1 + 0.00516) +
               (0.15346 * t3 - 0.26756 * t2 + 0.06670 * t1 + 0.26688);
  }

  // Linear sRGB of the sky at zenith angle θ (cos θ > 0) and angle γ from the sun, in kcd/m² of luminance.
  std::array<double, 3> rgb(double cosTheta, double gamma) const
  {
    const double Yv = zenithY * Y(cosTheta, gamma) / Y(1, thetaS);
    const double xv = zenithX * x(cosTheta, gamma) / x(1, thetaS);
    const double yv = zenithYc * y(cosTheta, gamma) / y(1, thetaS);
    // xyY -> XYZ -> linear sRGB (Rec. 709 primaries, D65).
    const double X = xv / yv * Yv, Z = (1 - xv - yv) / yv * Yv;
    return {std::max(0.0, 3.2406 * X - 1.5372 * Yv - 0.4986 * Z), std::max(0.0, -0.9689 * X + 1.8758 * Yv + 0.0415 * Z),
            std::max(0.0, 0.0557 * X - 0.2040 * Yv + 1.0570 * Z)};
  }
};
// [preetham]

const char* const kUsage = "usage: gen_sky OUT.exr|OUT.pfm [--elevation DEG (0-90, default 35)] [--azimuth DEG "
                           "(default 30)] [--turbidity T (2-10, default 3)] [--width W (default 512)] [--sun-ratio R "
                           "(default 5)]\n";

[[noreturn]] void usage(const std::string& why)
{
  std::cerr << "gen_sky: " << why << "\n" << kUsage;
  std::exit(2);
}

} // namespace

int main(int argc, char** argv)
{
  if (argc < 2)
    usage("no output file");
  const std::string out = argv[1];
  if (out == "--help" || out == "-h") {
    std::cout << kUsage;
    return 0;
  }
  if (out.starts_with('-'))
    usage("no output file (OUT comes first): " + out);
  double elevation = 35, azimuth = 30, turbidity = 3, sunRatio = 5;
  int width = 512;
  for (int i = 2; i < argc; ++i) {
    const std::string a = argv[i];
    if (i + 1 >= argc)
      usage("missing value after " + a);
    char* end = nullptr;
    const double v = std::strtod(argv[++i], &end);
    if (!end || *end || !std::isfinite(v))
      usage("not a number: " + std::string(argv[i]));
    if (a == "--elevation" && v > 0 && v <= 90)
      elevation = v;
    else if (a == "--azimuth")
      azimuth = v;
    else if (a == "--turbidity" && v >= 2 && v <= 10)
      turbidity = v;
    else if (a == "--width" && v >= 8 && v <= 16384 && v == std::floor(v) && int(v) % 2 == 0)
      width = int(v);
    else if (a == "--sun-ratio" && v >= 0 && v <= 1000)
      sunRatio = v;
    else
      usage("bad option or value out of range: " + a + " " + argv[i]);
  }
  const int height = width / 2;
  const double thetaS = (90 - elevation) * kPiD / 180, phiS = azimuth * kPiD / 180;
  const double sun[3] = {std::sin(thetaS) * std::sin(phiS), std::cos(thetaS), -std::sin(thetaS) * std::cos(phiS)};
  const SkyModel sky(turbidity, thetaS);
  const double kScale = 0.1; // kcd/m² -> the map's radiance

  Image map(width, height);
  auto direction = [&](double u, double v, double d[3]) {
    const double theta = kPiD * v, phi = 2 * kPiD * (u - 0.5);
    d[0] = std::sin(theta) * std::sin(phi), d[1] = std::cos(theta), d[2] = -std::sin(theta) * std::cos(phi);
  };
  // The sky above the horizon, and its irradiance on a horizontal surface.
  double skyIrradiance = 0;
  const double texelSolidAngle = 2 * kPiD * kPiD / (double(width) * height);
  for (int j = 0; j < height / 2; ++j)
    for (int i = 0; i < width; ++i) {
      double d[3];
      direction((i + 0.5) / width, (j + 0.5) / height, d);
      const double gamma = std::acos(std::clamp(d[0] * sun[0] + d[1] * sun[1] + d[2] * sun[2], -1.0, 1.0));
      const auto c = sky.rgb(d[1], gamma);
      for (int k = 0; k < 3; ++k)
        map.at(i, j, k) = float(c[std::size_t(k)] * kScale);
      const double sinTheta = std::sin(kPiD * (j + 0.5) / height);
      skyIrradiance += (0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]) * kScale * d[1] * sinTheta * texelSolidAngle;
    }
  // The sun: a disc of the sky's colour towards it, as bright as sunRatio × the sky's horizontal irradiance.
  const double texelAngle = kPiD / height;
  const double radius = std::max(0.27 * kPiD / 180, 1.5 * texelAngle);
  const double cosRadius = std::cos(radius);
  const auto tint = sky.rgb(std::max(sun[1], 0.05), 0);
  const double tintY = 0.2126 * tint[0] + 0.7152 * tint[1] + 0.0722 * tint[2];
  double discSolidAngle = 0;
  for (int j = 0; j < height / 2; ++j)
    for (int i = 0; i < width; ++i) {
      double d[3];
      direction((i + 0.5) / width, (j + 0.5) / height, d);
      if (d[0] * sun[0] + d[1] * sun[1] + d[2] * sun[2] >= cosRadius)
        discSolidAngle += std::sin(kPiD * (j + 0.5) / height) * texelSolidAngle;
    }
  const double sunLuminance = discSolidAngle > 0 ? sunRatio * skyIrradiance / discSolidAngle : 0;
  for (int j = 0; j < height / 2; ++j)
    for (int i = 0; i < width; ++i) {
      double d[3];
      direction((i + 0.5) / width, (j + 0.5) / height, d);
      if (d[0] * sun[0] + d[1] * sun[1] + d[2] * sun[2] >= cosRadius)
        for (int k = 0; k < 3; ++k)
          map.at(i, j, k) = float(tint[std::size_t(k)] / tintY * sunLuminance);
    }
  // Below the horizon: a grey ground of albedo 0.3 under the sky and the sun.
  const double ground = 0.3 * (skyIrradiance + sunRatio * skyIrradiance * sun[1]) / kPiD;
  for (int j = height / 2; j < height; ++j)
    for (int i = 0; i < width; ++i)
      for (int k = 0; k < 3; ++k)
        map.at(i, j, k) = float(ground);
  try {
    writeImage(map, out);
  } catch (const ImageIoError& e) {
    std::cerr << "gen_sky: " << e.what() << "\n";
    return 1;
  }
  std::cerr << "gen_sky: " << width << "x" << height << " sky, sun at elevation " << elevation << ", azimuth "
            << azimuth << ", turbidity " << turbidity << "; zenith " << sky.zenithY << " kcd/m2 -> " << out << "\n";
  return 0;
}
