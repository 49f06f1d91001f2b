// volk (Debian libvulkan-volk-dev ships it as a header and one C file): the Vulkan entry points
// as function pointers loaded at run time from libvulkan.so.1, so penumbra links no Vulkan
// library and runs on the CPU where none is installed. Compiled here as C++ (it is valid C++),
// with its warnings off: it is not our code.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wall"
#pragma GCC diagnostic ignored "-Wextra"
#include <volk.c>
#pragma GCC diagnostic pop
