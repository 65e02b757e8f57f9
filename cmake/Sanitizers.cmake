# PNSPLAT_SANITIZE=address builds everything with ASan+UBSan, =thread with TSan.
# pnsplat_sanitize_link is the flag that links the sanitizer's runtime (empty without one).
if(PNSPLAT_SANITIZE STREQUAL "address")
  set(pnsplat_sanitize_link -fsanitize=address,undefined)
  add_compile_options(-fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer)
elseif(PNSPLAT_SANITIZE STREQUAL "thread")
  set(pnsplat_sanitize_link -fsanitize=thread)
  add_compile_options(-fsanitize=thread -fno-omit-frame-pointer)
elseif(NOT PNSPLAT_SANITIZE STREQUAL "")
  message(FATAL_ERROR "PNSPLAT_SANITIZE must be address, thread or empty, not '${PNSPLAT_SANITIZE}'")
endif()
if(pnsplat_sanitize_link)
  add_link_options(${pnsplat_sanitize_link})
endif()
