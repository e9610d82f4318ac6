# Renders CHAPTER's default scene at 160x120 into WORK and compares it with GOLDEN (raylife_compare).
# On failure the difference image (x10) is left in WORK/difference.png for review.
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK})
execute_process(COMMAND ${CHAPTER} --width 160 --height 120 --quiet -o ${WORK}/image.pfm
                RESULT_VARIABLE render_status)
if(NOT render_status EQUAL 0)
  message(FATAL_ERROR "${CHAPTER} failed with status ${render_status}")
endif()
execute_process(COMMAND ${COMPARE} ${WORK}/image.pfm ${GOLDEN} --tolerance ${TOLERANCE}
                        --diff ${WORK}/difference.png --gain 10
                RESULT_VARIABLE compare_status)
if(NOT compare_status EQUAL 0)
  message(FATAL_ERROR "the image differs from ${GOLDEN}; see ${WORK}/difference.png")
endif()
