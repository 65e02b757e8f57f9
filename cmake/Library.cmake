# pnsplat_library(NAME SOURCES...): the static library pnsplat_NAME with its alias pnsplat::NAME
# (also its name in the installed package) and its public headers in NAME/include, found from the
# build tree and from the installed include folder alike.
function(pnsplat_library name)
  add_library(pnsplat_${name} STATIC ${ARGN})
  add_library(pnsplat::${name} ALIAS pnsplat_${name})
  set_target_properties(pnsplat_${name} PROPERTIES EXPORT_NAME ${name})
  target_include_directories(pnsplat_${name} PUBLIC
    $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include> $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
endfunction()
