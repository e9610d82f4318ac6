# Makes the docs' chapter pages and index from the one table of chapters, docs/chapters.txt, so that a chapter
# cannot be left out of the list or linked out of order:
#  - the index's "The chapters, in order" (the line @RAYLIFE_CHAPTERS@ in docs/index.md), every chapter with its
#    image, title and summary;
#  - each chapter page with its "Previous" and "Next" links (top and bottom), replacing any written by hand.
# It checks what the table must agree with, and fails naming the fault: every steps/NN_name/ folder has a row and
# every row a folder and a page, the rows are in the order of their numbers (a number may be missing: a chapter the
# curriculum has planned but not written yet keeps its place), and each page's heading is
# "# Chapter N — TITLE {#stepNN_name}" with the table's title.
#  - the scene-format page's table of what each chapter reads (@RAYLIFE_CHAPTER_READS@), from each chapter's
#    `--help` ("reads from a scene: ..."), when BIN_DIR holds the chapters' programs.
#   cmake -DSOURCE=<docs dir> -DSTEPS=<steps dir> -DOUT=<dir for the pages> [-DBIN_DIR=<dir>] [-DABSENT=<binaries>]
#         -P make_pages.cmake   (ABSENT: optional chapters the build does not make, listed without their --help)
cmake_policy(VERSION 3.20)
foreach(var SOURCE STEPS OUT)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "make_pages.cmake: -D${var}=... is required")
  endif()
endforeach()

file(STRINGS ${SOURCE}/chapters.txt rows ENCODING UTF-8)
set(pages)
set(n 0)
set(previous 0)
foreach(row IN LISTS rows)
  if(row MATCHES "^#" OR row STREQUAL "")
    continue()
  endif()
  if(NOT row MATCHES "^([0-9][0-9])_([a-z0-9_]+) \\| ([^|]+) \\| ([^|]+)$")
    message(FATAL_ERROR "docs/chapters.txt: '${row}' is not 'NN_name | TITLE | SUMMARY'")
  endif()
  math(EXPR n "${n} + 1")
  math(EXPR number "${CMAKE_MATCH_1}")
  set(page "${CMAKE_MATCH_1}_${CMAKE_MATCH_2}")
  if(NOT number GREATER previous)
    message(FATAL_ERROR "docs/chapters.txt: row ${n} is chapter ${number} (${page}), after chapter ${previous}; "
                        "the rows go in the order of the chapters' numbers")
  endif()
  set(previous ${number})
  set(number_${n} ${number})
  set(title_${n} "${CMAKE_MATCH_3}")
  set(summary_${n} "${CMAKE_MATCH_4}")
  set(page_${n} "${page}")
  set(binary_${n} "step${page}")
  if(NOT IS_DIRECTORY ${STEPS}/${page} OR NOT EXISTS ${SOURCE}/${page}.md)
    message(FATAL_ERROR "docs/chapters.txt: chapter ${number} (${page}) needs steps/${page}/ and docs/${page}.md")
  endif()
  list(APPEND pages ${page})
endforeach()
set(count ${n})
file(GLOB step_dirs LIST_DIRECTORIES true RELATIVE ${STEPS} ${STEPS}/[0-9][0-9]_*)
foreach(dir IN LISTS step_dirs)
  if(IS_DIRECTORY ${STEPS}/${dir} AND NOT dir IN_LIST pages)
    message(FATAL_ERROR "docs/chapters.txt: steps/${dir}/ has no row; add one, in order, for its page")
  endif()
endforeach()

function(chapter_ref i out)
  set(${out} "@ref ${binary_${i}} \"Chapter ${number_${i}} — ${title_${i}}\"" PARENT_SCOPE)
endfunction()

file(MAKE_DIRECTORY ${OUT})
# The chapter pages.
foreach(i RANGE 1 ${count})
  file(READ ${SOURCE}/${page_${i}}.md text)
  string(REGEX MATCH "^[^\n]*" heading "${text}")
  set(expected "# Chapter ${number_${i}} — ${title_${i}} {#${binary_${i}}}")
  if(NOT heading STREQUAL expected)
    message(FATAL_ERROR "docs/${page_${i}}.md: its heading is '${heading}'; docs/chapters.txt makes it '${expected}'")
  endif()
  # Drop hand-written previous/next lines; then the links, at the end of the list under the heading and at the
  # bottom of the page.
  string(REGEX REPLACE "\n- \\*\\*(Previous|Next|Previous, next):\\*\\*[^\n]*" "" text "${text}")
  set(links)
  if(i GREATER 1)
    math(EXPR p "${i} - 1")
    chapter_ref(${p} ref)
    list(APPEND links "**Previous:** ${ref}")
  endif()
  if(i LESS count)
    math(EXPR q "${i} + 1")
    chapter_ref(${q} ref)
    list(APPEND links "**Next:** ${ref}")
  endif()
  list(JOIN links " — " nav)
  string(FIND "${text}" "\n\n## " section)
  if(section EQUAL -1)
    message(FATAL_ERROR "docs/${page_${i}}.md: no '## ' section after its list of binary, source and lecture")
  endif()
  string(SUBSTRING "${text}" 0 ${section} head)
  string(SUBSTRING "${text}" ${section} -1 tail)
  file(WRITE ${OUT}/${page_${i}}.md "${head}\n- ${nav}${tail}\n\n<hr>\n${nav}\n")
endforeach()

# The index: the chapters' table in place of @RAYLIFE_CHAPTERS@.
set(table "<table class=\"raylife-chapters\">\n")
foreach(i RANGE 1 ${count})
  string(APPEND table "<tr>\n<td>\\image html ${binary_${i}}.png width=200px</td>\n"
                      "<td><b>${number_${i}}. @ref ${binary_${i}} \"${title_${i}}\"</b><br>\n${summary_${i}}</td>\n</tr>\n")
endforeach()
string(APPEND table "</table>")
file(READ ${SOURCE}/index.md index)
string(FIND "${index}" "@RAYLIFE_CHAPTERS@" at)
if(at EQUAL -1)
  message(FATAL_ERROR "docs/index.md: the line @RAYLIFE_CHAPTERS@, where the chapters' table goes, is missing")
endif()
string(REPLACE "@RAYLIFE_CHAPTERS@" "${table}" index "${index}")
file(WRITE ${OUT}/index.md "${index}")

# The scene format's table of what each chapter reads.
set(reads "| Chapter | Reads from a scene |\n| --- | --- |\n")
foreach(i RANGE 1 ${count})
  if(NOT DEFINED BIN_DIR)
    set(reads "(The table of what each chapter reads is made by the docs build, from the chapters' programs.)")
    break()
  endif()
  if(binary_${i} IN_LIST ABSENT)
    # An optional chapter this build does not make (chapter 17 without RAYLIFE_OPENCL): its page says what it reads.
    string(APPEND reads "| ${number_${i}}. @ref ${binary_${i}} \"${title_${i}}\" | (an optional build's: see its page) |\n")
    continue()
  endif()
  execute_process(COMMAND ${BIN_DIR}/${binary_${i}} --help OUTPUT_VARIABLE help RESULT_VARIABLE status)
  if(NOT status EQUAL 0 OR NOT help MATCHES "\nreads from a scene: ([^\n]+)\n")
    message(FATAL_ERROR "${BIN_DIR}/${binary_${i}} --help (status ${status}) does not say what it reads from a scene")
  endif()
  string(APPEND reads "| ${number_${i}}. @ref ${binary_${i}} \"${title_${i}}\" | ${CMAKE_MATCH_1} |\n")
endforeach()
# The table replaces the whole comment that holds its mark (a comment, so that the Markdown source reads well
# where it is shown as it is, on a code host, say).
file(READ ${SOURCE}/scene-format.md format)
string(FIND "${format}" "<!-- @RAYLIFE_CHAPTER_READS@" at)
if(at EQUAL -1)
  message(FATAL_ERROR "docs/scene-format.md: the comment <!-- @RAYLIFE_CHAPTER_READS@ ... -->, where the table of what "
                      "each chapter reads goes, is missing")
endif()
string(SUBSTRING "${format}" 0 ${at} before)
string(SUBSTRING "${format}" ${at} -1 rest)
string(FIND "${rest}" "-->" end)
math(EXPR end "${end} + 3")
string(SUBSTRING "${rest}" ${end} -1 after)
set(format "${before}${reads}${after}")
file(WRITE ${OUT}/scene-format.md "${format}")
message(STATUS "raylife docs: ${count} chapters listed and linked in order")
