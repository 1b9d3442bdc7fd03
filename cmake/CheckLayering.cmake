# The layering of the source tree, checked on every build (and by the layering.* tests):
#   core/                      includes only core/ (and the generated LCM types);
#   vo-proc/ ... mapper-proc/  (the five processes) and viewer/ include core/ and their own
#                              folder only: never tools/ (simulators, evaluation, data-set
#                              readers and offline runners are tools around a process, not part
#                              of it), never another process (what two processes share lives in
#                              core/, or travels between them as a message).
# Tools may include anything. Run: cmake -DEVERMAP_SOURCE_DIR=<tree> -P CheckLayering.cmake
# It fails with one line per offending #include.
if(NOT EVERMAP_SOURCE_DIR)
  message(FATAL_ERROR "CheckLayering.cmake: set -DEVERMAP_SOURCE_DIR=<source tree>")
endif()
set(process_dirs vo-proc imu-proc elevator-proc loopclose-proc mapper-proc viewer)
set(violations "")

# check(<folder> <regex of forbidden include paths> <what the rule says>)
function(evermap_check_folder folder forbidden rule)
  file(GLOB_RECURSE sources ${EVERMAP_SOURCE_DIR}/${folder}/*.h ${EVERMAP_SOURCE_DIR}/${folder}/*.cpp)
  foreach(src ${sources})
    file(STRINGS ${src} includes REGEX "^[ \t]*#[ \t]*include[ \t]+\"")
    foreach(line ${includes})
      string(REGEX REPLACE "^[ \t]*#[ \t]*include[ \t]+\"([^\"]*)\".*" "\\1" path "${line}")
      if(path MATCHES "${forbidden}")
        file(RELATIVE_PATH rel ${EVERMAP_SOURCE_DIR} ${src})
        set(violations "${violations}layering: ${rel} includes \"${path}\" (${rule})\n")
      endif()
    endforeach()
  endforeach()
  set(violations "${violations}" PARENT_SCOPE)
endfunction()

list(JOIN process_dirs "|" process_alternatives)
evermap_check_folder(core "^(tools|${process_alternatives})/"
                     "core/ holds what the processes share and includes only core/")
foreach(dir ${process_dirs})
  evermap_check_folder(${dir} "^tools/" "a process never includes a tool")
  set(others ${process_dirs})
  list(REMOVE_ITEM others ${dir})
  list(JOIN others "|" other_alternatives)
  evermap_check_folder(${dir} "^(${other_alternatives})/"
                       "a process includes core/ and its own folder, never another process")
endforeach()

if(violations)
  message(NOTICE "${violations}")
  message(FATAL_ERROR "layering: the includes above break the rule (cmake/CheckLayering.cmake)")
endif()
