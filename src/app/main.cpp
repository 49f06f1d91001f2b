// penumbra command line (filled in by the CLI work).
#include <cstdio>
int main() { std::puts("penumbra"); return 0; }
