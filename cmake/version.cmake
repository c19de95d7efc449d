# Writes the version header at BUILD time (run by the palplab_version target on every build), so
# a rebuild after a commit stamps results with the new commit. configure_file rewrites the file
# only when its content changes, so nothing recompiles when the commit did not change.
# Inputs: SRC (source tree), OUT (header path), VERSION (project version).
execute_process(COMMAND git rev-parse --short=12 HEAD WORKING_DIRECTORY "${SRC}"
                OUTPUT_VARIABLE PALPLAB_GIT_COMMIT OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
if(NOT PALPLAB_GIT_COMMIT)
  set(PALPLAB_GIT_COMMIT "unknown")
else()
  # Uncommitted changes to tracked files: the binary is not that commit.
  execute_process(COMMAND git status --porcelain --untracked-files=no WORKING_DIRECTORY "${SRC}"
                  OUTPUT_VARIABLE dirty OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
  if(dirty)
    string(APPEND PALPLAB_GIT_COMMIT "-dirty")
  endif()
endif()
set(PROJECT_VERSION "${VERSION}")
configure_file("${SRC}/common/version.hpp.in" "${OUT}" @ONLY)
