/// @file documented.h
/// @brief A fixture for the docs check: everything here is documented, so Doxygen must report nothing.
#pragma once

namespace fixture {

/// Twice `x`, for any int whose double fits in an int.
int twice(int x);

} // namespace fixture
