// The error type lives in common/ (shared by world/, vision/ and planning/).
#pragma once

#include "common/status.h"
