// rtukit core: everything, in one include.
#pragma once

#include "rtukit/core/crc.hpp"
#include "rtukit/core/error.hpp"
#include "rtukit/core/master.hpp"
#include "rtukit/core/mbap.hpp"
#include "rtukit/core/pdu.hpp"
#include "rtukit/core/rtu.hpp"
#include "rtukit/core/slave.hpp"
