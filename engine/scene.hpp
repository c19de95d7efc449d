#pragma once
// Top-level engine header: the Scene contract (see engine/haptics/scene.hpp).
#include "engine/haptics/scene.hpp"
