// The source of the targets that only carry tac3d's shared precompiled headers
// (cmake/PrecompiledHeaders.cmake); other targets reuse what they precompile.
int main() { return 0; }
