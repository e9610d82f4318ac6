# Renders CHAPTER with ARGS on 1 and on 2 threads and requires the two PFM files to be identical byte for byte.
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK})
foreach(threads 1 2)
  execute_process(COMMAND ${CHAPTER} --width 96 --height 64 --quiet --threads ${threads} ${ARGS}
                          -o ${WORK}/t${threads}.pfm
                  RESULT_VARIABLE status)
  if(NOT status EQUAL 0)
    message(FATAL_ERROR "${CHAPTER} --threads ${threads} failed with status ${status}")
  endif()
endforeach()
execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${WORK}/t1.pfm ${WORK}/t2.pfm RESULT_VARIABLE same)
if(NOT same EQUAL 0)
  message(FATAL_ERROR "the images rendered on 1 and 2 threads differ")
endif()
