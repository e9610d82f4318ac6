/// @file undocumented.h
/// @brief A fixture for the docs check: `forgotten` has no comment, so Doxygen must fail on it.
#pragma once

namespace fixture {

/// Twice `x`, for any int whose double fits in an int.
int twice(int x);

int forgotten(int x);

} // namespace fixture
