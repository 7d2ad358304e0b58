#include "tac3d/util/version.h"

namespace tac3d {

const char* Version() { return TAC3D_VERSION_STRING; }

}  // namespace tac3d
