# write_if_changed(FILE CONTENT): writes CONTENT to FILE unless FILE already holds it, so a
# generated source whose input did not change does not recompile (the embed_*.cmake scripts).
function(write_if_changed file content)
  if(EXISTS "${file}")
    file(READ "${file}" old)
    if(old STREQUAL content)
      return()
    endif()
  endif()
  file(WRITE "${file}" "${content}")
endfunction()
