# Checks that the built site works from the file system with no network.
#   cmake -DSITE=<html dir> -DPAGES="step01_camera;..." [-DBROWSER=<chromium>] -P check_site.cmake
# 1. No page loads a script or a style sheet from the network (a CDN): every <script src> and <link href> is local.
# 2. The MathJax copy is there.
# 3. With BROWSER (headless Chromium, every host unresolvable and every proxy dead, so nothing can be fetched),
#    each listed page is opened and, once its scripts have run, every formula on it must have been typeset by
#    MathJax, and every image it shows must exist beside it.
foreach(var SITE PAGES)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "check_site.cmake: -D${var}=... is required")
  endif()
endforeach()

set(faults)

# count_matches(OUT REGEX LENGTH TEXT): how many times REGEX, whose matches are all LENGTH characters long, occurs in TEXT.
# (Counted by length, not with a list: a CMake list miscounts elements that hold square brackets.)
function(count_matches out regex length text)
  string(LENGTH "${text}" before)
  string(REGEX REPLACE "${regex}" "" stripped "${text}")
  string(LENGTH "${stripped}" after)
  math(EXPR n "(${before} - ${after}) / ${length}")
  set(${out} ${n} PARENT_SCOPE)
endfunction()

# 1. Remote scripts or style sheets. (The pages are generated, so they are listed from the output folder.)
file(GLOB pages LIST_DIRECTORIES false "${SITE}/*.html")
if(NOT pages)
  list(APPEND faults "no HTML pages in ${SITE}")
endif()
foreach(page IN LISTS pages)
  file(STRINGS ${page} remote REGEX "<script[^>]*src=\"(https?:)?//|<link[^>]*href=\"(https?:)?//")
  if(remote)
    get_filename_component(name ${page} NAME)
    list(APPEND faults "${name} loads from the network: ${remote}")
  endif()
endforeach()

# 2. MathJax, as the pages reference it (MATHJAX_RELPATH = mathjax).
foreach(file mathjax/MathJax.js mathjax/jax/input/TeX/jax.js mathjax/jax/output/SVG/jax.js)
  if(NOT EXISTS ${SITE}/${file})
    list(APPEND faults "${file} is missing from the site")
  endif()
endforeach()

# 3. Formulas typeset and images present, in a browser that cannot reach any network.
if(DEFINED BROWSER AND BROWSER)
  foreach(page IN LISTS PAGES)
    set(html ${SITE}/${page}.html)
    if(NOT EXISTS ${html})
      list(APPEND faults "${page}.html is missing")
      continue()
    endif()
    # Doxygen writes each formula for MathJax as \( ... \) (inline) or \[ ... \] (display).
    file(READ ${html} source)
    count_matches(expected "\\\\[[(]" 2 "${source}")

    string(RANDOM LENGTH 12 tag)
    set(profile ${SITE}/../chromium-profile-${tag})
    execute_process(
      COMMAND ${BROWSER} --headless --no-sandbox --disable-gpu --no-first-run --disable-background-networking
              --disable-component-update --disable-sync --user-data-dir=${profile}
              --proxy-server=127.0.0.1:9 "--host-resolver-rules=MAP * ~NOTFOUND"
              --virtual-time-budget=20000 --dump-dom file://${html}
      OUTPUT_VARIABLE dom ERROR_QUIET RESULT_VARIABLE status TIMEOUT 120)
    file(REMOVE_RECURSE ${profile})
    if(NOT status EQUAL 0)
      list(APPEND faults "${page}: the browser failed (${status})")
      continue()
    endif()
    count_matches(got "class=\"MathJax_SVG\"" 19 "${dom}")
    string(REGEX MATCHALL "class=\"MathJax_Error\"|class=\"merror\"" errors "${dom}")
    if(expected EQUAL 0 OR NOT got EQUAL expected OR errors)
      list(APPEND faults "${page}: ${got} of ${expected} formulas typeset offline")
    endif()
    string(REGEX MATCHALL "<img [^>]*src=\"[^\"]+\"" images "${dom}")
    foreach(img IN LISTS images)
      string(REGEX REPLACE ".*src=\"([^\"]+)\".*" "\\1" src "${img}")
      if(NOT EXISTS ${SITE}/${src})
        list(APPEND faults "${page}: image ${src} is missing")
      endif()
    endforeach()
    message(STATUS "raylife docs: ${page}.html offline: ${got} of ${expected} formulas typeset, images present")
  endforeach()
else()
  # (Chromium is looked for when the build is configured: installed after that, it is found at the next configure,
  # which the docs workflow does.)
  message(STATUS "raylife docs: no Chromium when the build was configured, so the pages were not opened offline "
                 "(./setup.sh --browser installs it; then cmake --workflow --preset docs)")
endif()

if(faults)
  list(JOIN faults "\n  " text)
  message(FATAL_ERROR "raylife docs: the site does not work offline:\n  ${text}")
endif()
