# Warnings travel through one INTERFACE target; every project target links it.
add_library(pnsplat_warnings INTERFACE)
add_library(pnsplat::warnings ALIAS pnsplat_warnings)
target_compile_options(pnsplat_warnings INTERFACE
  -Wall -Wextra -Wpedantic -Wshadow -Wconversion -Wno-sign-conversion -Wnon-virtual-dtor
  -Wold-style-cast -Woverloaded-virtual -Wnull-dereference -Wdouble-promotion)
# Clang's -Wdouble-promotion also flags float-to-double conversions in initialisations
# (double d = f;), which the code uses on purpose where it computes in double; GCC's flags only
# promotions inside expressions.
if(CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
  target_compile_options(pnsplat_warnings INTERFACE -Wno-double-promotion)
endif()
if(PNSPLAT_WERROR)
  target_compile_options(pnsplat_warnings INTERFACE -Werror)
endif()
