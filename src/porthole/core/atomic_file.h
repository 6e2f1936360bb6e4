// Kept for the includes that name it: the output module is porthole/core/output.h.
#pragma once

#include "porthole/core/output.h"
