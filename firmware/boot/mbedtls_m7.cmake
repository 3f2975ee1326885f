# Mbed TLS for the Cortex-M7 images: Debian's source package of the release the host links
# (fetch_mbedtls.sh, cached in the build folder), the few sources that verify an ECDSA P-256
# signature of a SHA-256 digest, built as wdr_mbedcrypto_m7 with mbedtls_config_m7.h.
# Included by firmware/CMakeLists.txt in the cortex-m7 build only. When the source cannot be
# fetched there is no wdr_mbedcrypto_m7 and firmware/CMakeLists.txt skips the bootloader.
set(WDR_MBEDTLS_DIR "" CACHE PATH "Mbed TLS 2.28 source folder (empty: fetch Debian's source package into the build folder)")
if(NOT WDR_MBEDTLS_DIR)
  execute_process(COMMAND sh ${CMAKE_CURRENT_LIST_DIR}/fetch_mbedtls.sh ${CMAKE_BINARY_DIR}/_deps
                  OUTPUT_VARIABLE _wdr_mbedtls_src ERROR_VARIABLE _wdr_mbedtls_err RESULT_VARIABLE _wdr_mbedtls_rc
                  OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_STRIP_TRAILING_WHITESPACE)
  if(NOT _wdr_mbedtls_rc EQUAL 0)
    message(STATUS "${_wdr_mbedtls_err}: no Mbed TLS for the Cortex-M7, so no bootloader and no firmware image")
    return()
  endif()
else()
  set(_wdr_mbedtls_src ${WDR_MBEDTLS_DIR})
endif()
message(STATUS "Mbed TLS for the Cortex-M7: ${_wdr_mbedtls_src}")

set(_wdr_mbedtls_sources sha256 ecdsa ecp ecp_curves bignum asn1parse asn1write platform platform_util
    constant_time memory_buffer_alloc)
list(TRANSFORM _wdr_mbedtls_sources PREPEND ${_wdr_mbedtls_src}/library/)
list(TRANSFORM _wdr_mbedtls_sources APPEND .c)
add_library(wdr_mbedcrypto_m7 STATIC ${_wdr_mbedtls_sources})
target_include_directories(wdr_mbedcrypto_m7 SYSTEM PUBLIC ${_wdr_mbedtls_src}/include)
target_include_directories(wdr_mbedcrypto_m7 PUBLIC ${CMAKE_CURRENT_LIST_DIR})
target_compile_definitions(wdr_mbedcrypto_m7 PUBLIC MBEDTLS_CONFIG_FILE="mbedtls_config_m7.h")
# Someone else's code: its warnings are not ours to fix (-Werror stays for our sources). Speed
# over size: the bootloader hashes the whole application and verifies at every boot.
target_compile_options(wdr_mbedcrypto_m7 PRIVATE -w -O2)
