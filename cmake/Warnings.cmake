# raylife_warnings: the warning set every raylife target uses; RAYLIFE_WERROR turns them into errors. It is off
# unless the environment sets RAYLIFE_WERROR=1 when a build folder is first configured: .ci/run does, so that a
# warning fails CI, while a student's newer compiler, with warnings of its own, still builds the README's commands.
if("$ENV{RAYLIFE_WERROR}")
  set(raylife_werror_default ON)
else()
  set(raylife_werror_default OFF)
endif()
option(RAYLIFE_WERROR "Treat warnings as errors" ${raylife_werror_default})
add_library(raylife_warnings INTERFACE)
target_compile_options(raylife_warnings INTERFACE -Wall -Wextra -Wpedantic -Wshadow -Wconversion -Wno-sign-conversion)
if(RAYLIFE_WERROR)
  target_compile_options(raylife_warnings INTERFACE -Werror)
endif()
