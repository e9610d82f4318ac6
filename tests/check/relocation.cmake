# A build finds its scenes relative to itself, never through a path fixed when it was configured:
# 1. the chapter program holds no path of the source tree's scenes/;
# 2. a copied tree (its scenes/ and the program in its build/bin/) renders its own scenes: a background changed in
#    the copy shows in the copy's render;
# 3. tools/update_goldens.sh in a copied tree stops when the build fails, or when the build folder is another
#    tree's, and touches no golden.
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK}/tree/build/bin ${WORK}/tree/tools ${WORK}/tree/tests/golden)

file(STRINGS ${CHAPTER} baked REGEX "${SOURCE}/scenes")
if(baked)
  message(FATAL_ERROR "${CHAPTER} holds the source tree's scenes folder: ${baked}")
endif()

file(COPY ${SOURCE}/scenes DESTINATION ${WORK}/tree)
file(COPY ${CHAPTER} DESTINATION ${WORK}/tree/build/bin)
get_filename_component(name ${CHAPTER} NAME)
file(READ ${WORK}/tree/scenes/spheres.json scene)
string(REGEX REPLACE "\"background\": *\\[[^]]*\\]" "\"background\": [0.9, 0.1, 0.8]" changed "${scene}")
if(changed STREQUAL scene)
  message(FATAL_ERROR "could not change the background of the copied spheres.json")
endif()
file(WRITE ${WORK}/tree/scenes/spheres.json "${changed}")
foreach(run original copy)
  if(run STREQUAL original)
    set(program ${CHAPTER})
  else()
    set(program ${WORK}/tree/build/bin/${name})
  endif()
  execute_process(COMMAND ${CMAKE_COMMAND} -E env --unset=RAYLIFE_SCENES ${program} --width 32 --height 24 --quiet
                          -o ${WORK}/${run}.pfm RESULT_VARIABLE status)
  if(NOT status EQUAL 0)
    message(FATAL_ERROR "${program} failed with ${status}")
  endif()
endforeach()
execute_process(COMMAND ${program} ${WORK}/tree/scenes/spheres.json --width 32 --height 24 --quiet
                        -o ${WORK}/expected.pfm RESULT_VARIABLE status)
execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${WORK}/copy.pfm ${WORK}/expected.pfm RESULT_VARIABLE same)
if(NOT same EQUAL 0)
  message(FATAL_ERROR "the copied program did not render the copy's scenes/spheres.json")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${WORK}/copy.pfm ${WORK}/original.pfm RESULT_VARIABLE same)
if(same EQUAL 0)
  message(FATAL_ERROR "the copy's change did not show: the copied program rendered the original's scene")
endif()

# update_goldens.sh: a build that fails to compile, then a build folder configured for another tree.
file(COPY ${SOURCE}/tools/update_goldens.sh DESTINATION ${WORK}/tree/tools)
file(WRITE ${WORK}/tree/tests/golden/sentinel.pfm "untouched")
file(WRITE ${WORK}/tree/CMakeLists.txt "cmake_minimum_required(VERSION 3.20)\nproject(broken NONE)\n"
           "add_custom_target(raylife_check COMMAND ${CMAKE_COMMAND} -E false)\n"
           "add_custom_target(raylife_compare)\n")
execute_process(COMMAND ${CMAKE_COMMAND} -S ${WORK}/tree -B ${WORK}/tree/build OUTPUT_QUIET RESULT_VARIABLE status)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "could not configure the broken tree")
endif()
foreach(build ${WORK}/tree/build ${WORK}/other)
  if(build STREQUAL "${WORK}/other")
    file(MAKE_DIRECTORY ${WORK}/other-tree)
    file(WRITE ${WORK}/other-tree/CMakeLists.txt "cmake_minimum_required(VERSION 3.20)\nproject(other NONE)\n")
    execute_process(COMMAND ${CMAKE_COMMAND} -S ${WORK}/other-tree -B ${build} OUTPUT_QUIET)
  endif()
  execute_process(COMMAND bash ${WORK}/tree/tools/update_goldens.sh ${build} RESULT_VARIABLE status
                  OUTPUT_VARIABLE out ERROR_VARIABLE err)
  message(STATUS "update_goldens.sh ${build}: ${status}: ${err}")
  if(status EQUAL 0 OR NOT err MATCHES "update_goldens: ")
    message(FATAL_ERROR "update_goldens.sh went on with ${build}: ${status}\n${out}${err}")
  endif()
  file(READ ${WORK}/tree/tests/golden/sentinel.pfm sentinel)
  file(GLOB goldens ${WORK}/tree/tests/golden/*)
  list(LENGTH goldens count)
  if(NOT sentinel STREQUAL "untouched" OR NOT count EQUAL 1)
    message(FATAL_ERROR "update_goldens.sh touched the goldens after a failed build")
  endif()
endforeach()
