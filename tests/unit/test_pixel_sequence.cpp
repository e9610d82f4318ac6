// PixelSequence (rng.h): Sobol's first two dimensions, Owen-scrambled per pixel. Each aligned block of 2^k points
// is a (0, k, 2)-net, and a point's position is uniform over pixels (the scramble is what makes it random).
#include "core/rng.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <tuple>
#include <vector>

using namespace raylife;

TEST_CASE("Sobol's second dimension starts as the published sequence")
{
  // In the index's own order (not Antonov and Saleev's Gray-code order, which visits each block's points in
  // another order): the generator matrix is Pascal's triangle mod 2, so 0, 1/2, 3/4, 1/4, 5/8, 1/8, 3/8, 7/8.
  const double expected[8] = {0, 0.5, 0.75, 0.25, 0.625, 0.125, 0.375, 0.875};
  for (std::uint32_t i = 0; i < 8; ++i)
    CHECK(double(PixelSequence::reverseBits(PixelSequence::sobolSecondReversed(i))) * 0x1p-32 == expected[i]);
  CHECK(PixelSequence::reverseBits(1u) == 0x80000000u);
  CHECK(PixelSequence::reverseBits(0x12345678u) == 0x1e6a2c48u);
}

TEST_CASE("every aligned block of 2^k points of a pixel's sequence is a (0, k, 2)-net")
{
  // In each block, every box of 2^i by 2^(k-i) cells holds exactly one point, for every split i of k.
  const std::vector<std::tuple<std::uint64_t, int, int>> pixels{{0, 0, 0}, {7, 13, 2}, {99, 319, 239}};
  for (const auto& [seed, x, y] : pixels) {
    const PixelSequence sequence(seed, x, y);
    for (int k = 0; k <= 8; ++k)
      for (std::uint32_t block = 0; block < 3; ++block) {
        const std::uint32_t n = 1u << k;
        bool net = true;
        for (int i = 0; i <= k; ++i) {
          const int nx = 1 << i, ny = 1 << (k - i);
          std::vector<int> count(std::size_t(nx * ny), 0);
          for (std::uint32_t j = 0; j < n; ++j) {
            const Vec2 p = sequence.point(block * n + j);
            REQUIRE(p.x >= 0);
            REQUIRE(p.x < 1);
            REQUIRE(p.y >= 0);
            REQUIRE(p.y < 1);
            count[std::size_t(int(p.y * Real(ny)) * nx + int(p.x * Real(nx)))] += 1;
          }
          for (int c : count)
            net = net && c == 1;
        }
        INFO("seed " << seed << ", pixel " << x << "," << y << ", k " << k << ", block " << block);
        CHECK(net);
      }
  }
}

TEST_CASE("a sequence point is uniform over the pixels (the scramble differs from pixel to pixel)")
{
  // Point 0 and point 5 of 16,384 pixels' sequences in an 8 x 8 grid: chi-square with 63 degrees of freedom,
  // fixed seed; 110 is above its 0.9998 quantile. Without the scramble every pixel's point 0 is (0, 0).
  for (std::uint32_t index : {0u, 5u}) {
    std::vector<int> count(64, 0);
    const int pixels = 16384;
    for (int p = 0; p < pixels; ++p) {
      const Vec2 u = PixelSequence(3, p % 128, p / 128).point(index);
      count[std::size_t(int(u.y * 8) * 8 + int(u.x * 8))] += 1;
    }
    const double expected = pixels / 64.0;
    double chi2 = 0;
    for (int c : count)
      chi2 += (c - expected) * (c - expected) / expected;
    INFO("point " << index << ": chi-square " << chi2);
    CHECK(chi2 < 110);
  }
}
