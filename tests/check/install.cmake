# cmake --install into a fresh prefix (issue 43): an installed chapter renders its default scene from any folder,
# from PREFIX/share/raylife/scenes, and the installed raylife_check grades it against PREFIX/share/raylife/golden.
# BUILD: the build folder. The prefix is a fresh folder in the system's temporary folder, outside any raylife tree:
# under the source tree (where the build folder usually is) the programs would find the tree's scenes first.
set(tmp /tmp)
if(DEFINED ENV{TMPDIR} AND IS_DIRECTORY "$ENV{TMPDIR}")
  set(tmp "$ENV{TMPDIR}")
endif()
string(RANDOM LENGTH 12 tag)
set(WORK ${tmp}/raylife_install_test_${tag})
file(REMOVE_RECURSE ${WORK})
execute_process(COMMAND ${CMAKE_COMMAND} --install ${BUILD} --prefix ${WORK}/prefix RESULT_VARIABLE status
                OUTPUT_QUIET ERROR_VARIABLE err)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "cmake --install failed (${status}): ${err}")
endif()
file(MAKE_DIRECTORY ${WORK}/elsewhere)
set(clean ${CMAKE_COMMAND} -E env --unset=RAYLIFE_SCENES --unset=RAYLIFE_GOLDEN)
execute_process(COMMAND ${clean} ${WORK}/prefix/bin/step04_shadows --quiet WORKING_DIRECTORY ${WORK}/elsewhere
                RESULT_VARIABLE status ERROR_VARIABLE err)
if(NOT status EQUAL 0 OR NOT EXISTS ${WORK}/elsewhere/out/step04_shadows.png)
  file(REMOVE_RECURSE ${WORK})
  message(FATAL_ERROR "the installed step04_shadows did not render its default scene (${status}): ${err}")
endif()
execute_process(COMMAND ${clean} ${WORK}/prefix/bin/raylife_check 4 out/step04_shadows.png
                WORKING_DIRECTORY ${WORK}/elsewhere RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE err)
file(REMOVE_RECURSE ${WORK})
if(NOT status EQUAL 0 OR NOT out MATCHES "prefix/share/raylife/golden/step04_shadows.png")
  message(FATAL_ERROR "the installed raylife_check did not pass the default render against the installed golden "
                      "(${status}): ${out}${err}")
endif()
message(STATUS "${out}")
