# raylife_warnings: the warning set every raylife target uses; RAYLIFE_WERROR turns them into errors (CI).
option(RAYLIFE_WERROR "Treat warnings as errors" OFF)
add_library(raylife_warnings INTERFACE)
target_compile_options(raylife_warnings INTERFACE -Wall -Wextra -Wpedantic -Wshadow -Wconversion -Wno-sign-conversion)
if(RAYLIFE_WERROR)
  target_compile_options(raylife_warnings INTERFACE -Werror)
endif()
