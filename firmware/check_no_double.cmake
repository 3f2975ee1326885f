# Fail the build if a per-pixel object calls the soft double-precision helpers (__aeabi_d*),
# and float<->double conversions (__aeabi_f2d, __aeabi_i2d, ...), which is how `double` maths
# shows up on a single-precision FPU.
# -DNM=arm-none-eabi-nm -DLIBS=a.a;b.a -DOBJECTS=correct.c.obj;...
set(found "")
foreach(lib ${LIBS})
  execute_process(COMMAND ${NM} -A --undefined-only ${lib} OUTPUT_VARIABLE out RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "check_no_double: ${NM} failed on ${lib}")
  endif()
  string(REPLACE "\n" ";" lines "${out}")
  foreach(line ${lines})
    foreach(obj ${OBJECTS})
      if(line MATCHES ":${obj}:.*__aeabi_(d|[a-z0-9]*2d)")
        list(APPEND found "${line}")
      endif()
    endforeach()
  endforeach()
endforeach()
if(found)
  message(FATAL_ERROR "double-precision calls in the per-pixel path:\n${found}")
endif()
message(STATUS "per-pixel path: no __aeabi_d* calls in ${OBJECTS}")
