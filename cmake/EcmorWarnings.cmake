# ecmor_set_warnings(target): warnings on for our own targets; -Werror when ECMOR_WERROR (CI).
function(ecmor_set_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow)
  if(ECMOR_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()
