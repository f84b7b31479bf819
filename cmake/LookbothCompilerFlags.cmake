# Warning flags for project code only (third-party headers are SYSTEM includes).
set(LOOKBOTH_WARNING_FLAGS -Wall -Wextra -Wpedantic -Wno-psabi)
if(LOOKBOTH_WERROR)
  list(APPEND LOOKBOTH_WARNING_FLAGS -Werror)
endif()
