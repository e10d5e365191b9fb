# The repository is self-contained: no file in it reads or names the folder of
# data that sat beside the project's first checkout (".." + "/shared", or its
# absolute path "/work" + "/shared"), which a user who clones the project does
# not have; the real data sets are in data/real. Comment lines of the files in
# .ci/ may mention it (they say CI runs without it).
#   cmake -DSOURCE_DIR=<dir> [-DLIST=git|walk] -P self_contained.cmake
#   cmake -DSOURCE_DIR=<dir> -DSELF_TEST=ON -P self_contained.cmake
# LIST=git (the default): the files `git ls-files` lists, or every file under
# SOURCE_DIR as with walk when git is not installed or SOURCE_DIR is not a git
# work tree. LIST=walk: every file under SOURCE_DIR except .git, the build trees
# (build*/ and every folder holding a CMakeCache.txt) and hapticcal-out/.
# SELF_TEST=ON: the check run on two scratch folders, one that names the folder
# outside a comment of .ci/ (must fail) and one that does so only in a .ci/
# comment (must pass).
cmake_minimum_required(VERSION 3.16)  # CMP0053 NEW: file contents read as they are
# The patterns are put together here so that this file does not name them.
string(CONCAT relative_pattern ".." "/shared")
string(CONCAT absolute_pattern "/work" "/shared")

if(NOT SOURCE_DIR)
  message(FATAL_ERROR "usage: cmake -DSOURCE_DIR=<dir> [-DLIST=git|walk] -P self_contained.cmake")
endif()

if(SELF_TEST)
  set(scratch "${CMAKE_CURRENT_BINARY_DIR}/self_contained_self_test")
  file(REMOVE_RECURSE "${scratch}")
  # Folder "bad": a test reads the folder, a comment in .ci/ names it, and a
  # build tree that names it is skipped. Must fail, naming the test's file.
  file(WRITE "${scratch}/bad/tests/a_test.cpp"
       "const char* p = \"${relative_pattern}/data/x.csv\";\n")
  file(WRITE "${scratch}/bad/.ci/run" "# runs without ${relative_pattern}\nmake test\n")
  file(WRITE "${scratch}/bad/build/CMakeCache.txt" "${absolute_pattern}\n")
  # Folder "good": the same .ci/ comment and build tree, and a non-comment line
  # of .ci/ that does not name it.
  file(WRITE "${scratch}/good/README.md" "Data sets: data/real.\n")
  file(WRITE "${scratch}/good/.ci/run" "  # runs without ${relative_pattern}\nmake test\n")
  file(WRITE "${scratch}/good/build/CMakeCache.txt" "${absolute_pattern}\n")
  file(WRITE "${scratch}/good/out/CMakeCache.txt" "${relative_pattern}\n")
  # A .ci/ line that is not a comment must fail too.
  file(WRITE "${scratch}/ci_command/.ci/run" "ls ${absolute_pattern}/data\n")
  foreach(case bad good ci_command)
    execute_process(COMMAND "${CMAKE_COMMAND}" -DSOURCE_DIR=${scratch}/${case} -DLIST=walk
                            -P "${CMAKE_CURRENT_LIST_FILE}"
                    RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
    message("${case}: exit ${rc}\n${out}${err}")
    set(result_${case} "${rc}")
    set(output_${case} "${out}${err}")
  endforeach()
  if(result_bad EQUAL 0 OR NOT output_bad MATCHES "tests/a_test.cpp"
     OR output_bad MATCHES "\\.ci/run" OR output_bad MATCHES "CMakeCache")
    message(FATAL_ERROR "self test: the folder 'bad' must fail on tests/a_test.cpp alone")
  endif()
  if(NOT result_good EQUAL 0)
    message(FATAL_ERROR "self test: the folder 'good' must pass")
  endif()
  if(result_ci_command EQUAL 0 OR NOT output_ci_command MATCHES "\\.ci/run")
    message(FATAL_ERROR "self test: a command line of .ci/ naming the folder must fail")
  endif()
  file(REMOVE_RECURSE "${scratch}")
  message("self test passed")
  return()
endif()

get_filename_component(SOURCE_DIR "${SOURCE_DIR}" ABSOLUTE)
if(NOT LIST)
  set(LIST git)
endif()

set(files "")
set(how "")
if(LIST STREQUAL "git")
  find_program(GIT_EXECUTABLE git)
  if(GIT_EXECUTABLE)
    execute_process(COMMAND "${GIT_EXECUTABLE}" -C "${SOURCE_DIR}" ls-files
                    RESULT_VARIABLE rc OUTPUT_VARIABLE listed ERROR_VARIABLE git_err)
    if(rc EQUAL 0 AND NOT listed STREQUAL "")
      # One path a line; a path with a ';' would split into two list items, and
      # git quotes unusual names: neither occurs in this repository.
      string(REPLACE ";" "\\;" listed "${listed}")
      string(REPLACE "\n" ";" files "${listed}")
      set(how "git ls-files")
    else()
      message("git ls-files failed (${rc}: ${git_err}): walking the folder instead")
    endif()
  else()
    message("git is not installed: walking the folder instead")
  endif()
elseif(NOT LIST STREQUAL "walk")
  message(FATAL_ERROR "LIST must be git or walk, not ${LIST}")
endif()

if(how STREQUAL "")
  set(how "a walk of the folder")
  file(GLOB_RECURSE all RELATIVE "${SOURCE_DIR}" LIST_DIRECTORIES false "${SOURCE_DIR}/*")
  # Build trees: every folder holding a CMakeCache.txt, whatever its name.
  set(build_trees "")
  foreach(f IN LISTS all)
    if(f MATCHES "(^|/)CMakeCache\\.txt$")
      get_filename_component(tree "${f}" DIRECTORY)
      if(NOT tree STREQUAL "")  # not an in-source build: that would skip everything
        list(APPEND build_trees "${tree}/")
      endif()
    endif()
  endforeach()
  foreach(f IN LISTS all)
    if(f MATCHES "^(\\.git(/|$)|build[^/]*/|hapticcal-out/)")  # .git: a file in a worktree
      continue()
    endif()
    set(in_tree FALSE)
    foreach(tree IN LISTS build_trees)
      string(FIND "${f}" "${tree}" at)
      if(at EQUAL 0)
        set(in_tree TRUE)
        break()
      endif()
    endforeach()
    if(NOT in_tree)
      list(APPEND files "${f}")
    endif()
  endforeach()
endif()

set(offenders "")
set(checked 0)
foreach(f IN LISTS files)
  if(f STREQUAL "" OR NOT EXISTS "${SOURCE_DIR}/${f}" OR IS_DIRECTORY "${SOURCE_DIR}/${f}")
    continue()
  endif()
  math(EXPR checked "${checked} + 1")
  file(READ "${SOURCE_DIR}/${f}" content)
  if(f MATCHES "^\\.ci/")
    # Whole-line comments (#, after any indentation) of .ci/ may name it.
    string(REGEX REPLACE "(^|\n)[ \t]*#[^\n]*" "\\1" content "${content}")
  endif()
  foreach(pattern "${relative_pattern}" "${absolute_pattern}")
    string(FIND "${content}" "${pattern}" at)
    if(NOT at EQUAL -1)
      list(APPEND offenders "${f} (${pattern})")
      break()
    endif()
  endforeach()
endforeach()

if(checked EQUAL 0)
  message(FATAL_ERROR "no files found under ${SOURCE_DIR} (${how})")
endif()
if(offenders)
  list(JOIN offenders "\n  " text)
  message(FATAL_ERROR "${checked} files (${how}); these name the data folder beside the "
                      "first checkout, which a clone does not have (use data/real):\n  ${text}")
endif()
message("${checked} files (${how}): none names the data folder beside the first checkout")
