# weldtwin_warnings(target): the one place that decides the project's compiler warnings.
# -Warray-bounds stays a warning only: GCC 12 reports false positives inside Eigen.
function(weldtwin_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor
                                           -Wno-array-bounds)
  if(WELDTWIN_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()
