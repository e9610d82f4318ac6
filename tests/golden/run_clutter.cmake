# Renders smallpt's room (SCENE) bare and with 3,000 small spheres added behind its back wall (gen_spheres clutter,
# GEN), where no ray from the room can reach, and requires the two PFM files to be identical byte for byte: with
# the walls kept out of the tree (docs/09_bvh.md) the room over clutter finds the same hits as the bare room.
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK})
execute_process(COMMAND ${GEN} clutter ${SCENE} 3000 1 1 1 -100 99 80 -2 OUTPUT_FILE ${WORK}/clutter.json
                RESULT_VARIABLE status)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "gen_spheres clutter failed with status ${status}")
endif()
foreach(scene ${SCENE} ${WORK}/clutter.json)
  get_filename_component(name ${scene} NAME_WE)
  execute_process(COMMAND ${CHAPTER} ${scene} --width 48 --height 36 --spp 4 --quiet --verbose -o ${WORK}/${name}.pfm
                  RESULT_VARIABLE status ERROR_VARIABLE plan)
  if(NOT status EQUAL 0)
    message(FATAL_ERROR "${CHAPTER} ${scene} failed with status ${status}: ${plan}")
  endif()
  if(name STREQUAL "clutter" AND NOT plan MATCHES "huge primitives outside the tree[^\n]*spheres 0-5")
    message(FATAL_ERROR "the plan does not keep the walls out of the tree: ${plan}")
  endif()
endforeach()
execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${WORK}/smallpt.pfm ${WORK}/clutter.pfm RESULT_VARIABLE same)
if(NOT same EQUAL 0)
  message(FATAL_ERROR "the room over clutter renders differently from the bare room")
endif()
