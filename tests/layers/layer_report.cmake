# Shared by the layer checks: print a graph's edges with their counts, and fail with the list of
# bad edges under a heading. Included by check_layers.cmake and check_cal_stages.cmake, so both
# reports read the same way.

# Prints "  from -> to: count" once per distinct edge, sorted.
function(layer_report_edges)
  set(edges ${ARGN})
  list(SORT edges)
  set(seen "")
  foreach(e ${edges})
    list(FIND seen "${e}" found)
    if(found EQUAL -1)
      list(APPEND seen "${e}")
      set(n 0)
      foreach(e2 ${edges})
        if(e2 STREQUAL e)
          math(EXPR n "${n} + 1")
        endif()
      endforeach()
      message(STATUS "  ${e}: ${n}")
    endif()
  endforeach()
endfunction()

# Fails with `heading` and one line per bad edge, when there are any.
function(layer_fail_on_bad heading)
  set(bad ${ARGN})
  if(bad)
    string(REPLACE ";" "\n  " bad_text "${bad}")
    message(FATAL_ERROR "${heading}:\n  ${bad_text}")
  endif()
endfunction()
