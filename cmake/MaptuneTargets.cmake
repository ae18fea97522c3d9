# One place for warnings and target conventions.

# maptune_set_warnings(target): the project's warning set, as errors when MAPTUNE_WERROR.
function(maptune_set_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic $<$<CXX_COMPILER_ID:GNU>:-Wshadow=local>
                                           -Wnon-virtual-dtor
                                           -Wno-missing-field-initializers)
  if(MAPTUNE_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
  # (partial aggregate initialization of plain structs is intended: unset fields take defaults)
  # GCC 12 reports false -Warray-bounds inside Eigen's Umeyama (reached through PCL's ICP).
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
    target_compile_options(${target} PRIVATE -Wno-error=array-bounds -Wno-array-bounds)
  endif()
endfunction()

# maptune_library(NAME SOURCES ... [PUBLIC_DEPS ...] [PRIVATE_DEPS ...])
# Creates static library maptune_<NAME> with alias maptune::<NAME>. Headers are included as
# "<NAME>/header.hpp" from libs/.
function(maptune_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;PUBLIC_DEPS;PRIVATE_DEPS" ${ARGN})
  add_library(maptune_${name} STATIC ${ARG_SOURCES})
  add_library(maptune::${name} ALIAS maptune_${name})
  target_include_directories(maptune_${name} PUBLIC ${PROJECT_SOURCE_DIR}/libs
                                                    ${PROJECT_BINARY_DIR}/generated)
  target_link_libraries(maptune_${name} PUBLIC ${ARG_PUBLIC_DEPS} PRIVATE ${ARG_PRIVATE_DEPS})
  set_target_properties(maptune_${name} PROPERTIES POSITION_INDEPENDENT_CODE ON)
  maptune_set_warnings(maptune_${name})
endfunction()

# maptune_test(NAME SOURCES ... DEPS ...): a GoogleTest executable registered with ctest.
function(maptune_test name)
  # SERIAL: ctest runs these tests alone (gtest_discover_tests fills the test list only at
  # test time, so set_tests_properties on it at configure time would set nothing).
  cmake_parse_arguments(ARG "SERIAL" "TIMEOUT" "SOURCES;DEPS;LABELS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS} GTest::gtest GTest::gtest_main GTest::gmock)
  target_include_directories(${name} PRIVATE ${PROJECT_SOURCE_DIR}/tests/common)
  target_compile_definitions(${name} PRIVATE
    MAPTUNE_SOURCE_DIR="${PROJECT_SOURCE_DIR}"
    MAPTUNE_BINARY_DIR="${PROJECT_BINARY_DIR}")
  maptune_set_warnings(${name})
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 300)
  endif()
  # Empty values would shift gtest_discover_tests' property list: add only what is set.
  set(props TIMEOUT ${ARG_TIMEOUT})
  if(ARG_LABELS)
    list(APPEND props LABELS "${ARG_LABELS}")
  endif()
  if(ARG_SERIAL)
    list(APPEND props RUN_SERIAL TRUE)
  endif()
  gtest_discover_tests(${name} DISCOVERY_TIMEOUT 60 PROPERTIES ${props})
endfunction()

# maptune_sdk_header_test(NAME test TARGET plugin SOURCE file): the SDK promise, checked — no
# DDS header (Fast DDS, Fast CDR, the generated types, maptune's DDS layer) reaches the plug-in's
# translation unit. The compiler lists every header `file` includes, with exactly the include
# paths and definitions `plugin` gets (cmake/check_sdk_headers.cmake).
function(maptune_sdk_header_test)
  cmake_parse_arguments(ARG "" "NAME;TARGET;SOURCE" "" ${ARGN})
  add_test(NAME ${ARG_NAME}
           COMMAND ${CMAKE_COMMAND}
                   -DCXX=${CMAKE_CXX_COMPILER}
                   "-DINCLUDES=$<TARGET_PROPERTY:${ARG_TARGET},INCLUDE_DIRECTORIES>"
                   "-DDEFINES=$<TARGET_PROPERTY:${ARG_TARGET},COMPILE_DEFINITIONS>"
                   -DSOURCE=${ARG_SOURCE}
                   -P ${PROJECT_SOURCE_DIR}/cmake/check_sdk_headers.cmake)
endfunction()
