# Warnings for palpate's own targets (third-party headers come in as SYSTEM and stay quiet).
add_library(palpate_warnings INTERFACE)
target_compile_options(palpate_warnings INTERFACE
  -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Woverloaded-virtual
  -Wcast-align -Wformat=2 -Wimplicit-fallthrough -Wmissing-declarations
  $<$<BOOL:${PALPATE_WERROR}>:-Werror>)
