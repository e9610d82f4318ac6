# Exercises (docs/golden-tests.md, each chapter's "Try it yourself"): with RAYLIFE_EXERCISES=ON (the `exercises`
# preset, which builds in a folder of its own, build-exercises/, so that a half-written exercise never breaks the
# render and test builds in build/, and without link-time optimisation, so that rebuilding one after an edit takes
# seconds) every chapter also builds as BINARY_exercise from its exercise, a copy of its main.cpp with the bodies of
# the functions its page shows taken out (cmake/make_exercise.cmake). The copy is written once, into
# RAYLIFE_EXERCISES_DIR/NN_name/main.cpp, and never overwritten: it is the student's to edit.
include(${CMAKE_CURRENT_LIST_DIR}/make_exercise.cmake)
option(RAYLIFE_EXERCISES "Also build every chapter as an exercise with its idea taken out" OFF)
set(RAYLIFE_EXERCISES_DIR "${CMAKE_BINARY_DIR}/exercises" CACHE PATH "Where the exercises' sources are written")

# raylife_exercise(FOLDER BINARY): the exercise of the chapter in steps/FOLDER, when exercises are on.
function(raylife_exercise folder binary)
  if(NOT RAYLIFE_EXERCISES)
    return()
  endif()
  set(source ${RAYLIFE_EXERCISES_DIR}/${folder}/main.cpp)
  if(NOT EXISTS ${source})
    string(REGEX MATCH "^[0-9]+" number ${folder})
    math(EXPR number "${number}")
    raylife_make_exercise(${PROJECT_SOURCE_DIR}/steps/${folder}/main.cpp ${source} ${number} docs/${folder}.md)
    message(STATUS "raylife: exercise ${source} (${CMAKE_BINARY_DIR}/bin/${binary}_exercise)")
  endif()
  add_executable(${binary}_exercise ${source})
  set_property(GLOBAL APPEND PROPERTY RAYLIFE_EXERCISE_TARGETS ${binary}_exercise)
  target_link_libraries(${binary}_exercise PRIVATE raylife::common raylife_warnings)
  # Until it is written, the stub leaves parameters and helpers unused. (On the source, so the flags come after
  # -Wextra: clang takes the last one given.)
  set_source_files_properties(${source} PROPERTIES
    COMPILE_OPTIONS "-Wno-unused-parameter;-Wno-unused-function;-Wno-unused-variable")
endfunction()
