#pragma once

// Umbrella header of the autograd layer.
#include "autograd/dtype.h"
#include "autograd/engine.h"
#include "autograd/float_environment.h"
#include "autograd/generator.h"
#include "autograd/grad_mode.h"
#include "autograd/gradcheck.h"
#include "autograd/matmul_precision.h"
#include "autograd/node.h"
#include "autograd/ops.h"
#include "autograd/parallel.h"
#include "autograd/shape.h"
#include "autograd/tensor.h"
