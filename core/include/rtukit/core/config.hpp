// rtukit core: compile-time feature switches, one per function family.
//
// Each switch is 1 (compiled in, the default) or 0 (left out). The CMake
// options of the same name (core/CMakeLists.txt, all ON by default) set them
// as PUBLIC compile definitions of rtukit_core, so the core and every file
// that includes its headers see the same values (they change declarations
// and the size of SlaveEngine). Without CMake, define them the same way for
// every translation unit. The rest of rtukit (io, driver, devices, CLI) needs
// them all on; only a core-only build (RTUKIT_CORE_ONLY) may turn them off.
//
// What is always there: CRC-16, the RTU framer for requests, the PDU decoder
// for 03, 04, 06 and 10 (with the Inverjet's FC10 form), the slave engine
// with exception answers, its counters and line counters, Error/errc_name.
//
// A function whose family is off is not decoded: the slave answers exception
// 01 (illegal function), as for a function code rtukit never implemented; the
// framer frames it by silence (t3.5) and CRC, as any unknown function; its
// encoders and decoders are not compiled in (their declarations are gone, so
// a use is a compile error, not a silent change).
//
// RTUKIT_CORE_MASTER          the master side: MasterTransaction, the request
//                             encoders (encode_request, encode_read_request,
//                             encode_write_*, ...), decode_response and
//                             Response, and the framer's response shapes (a
//                             FrameShape::response framer then frames by
//                             silence and CRC only).
// RTUKIT_CORE_TCP             Modbus TCP: mbap.hpp's functions (the MBAP
//                             header), SlaveEngine::handle_tcp,
//                             MasterTransaction::accept_tcp, begin() over
//                             Framing::tcp (invalid_argument). handle_pdu keeps
//                             its Framing argument.
// RTUKIT_CORE_COILS           01 read coils, 02 read discrete inputs, 05 write
//                             single coil, 0F write multiple coils.
// RTUKIT_CORE_DIAGNOSTICS     the serial line diagnostics 07, 08, 0B, 0C, and
//                             what only they read: the event log (64 bytes of
//                             RAM) and listen-only mode (listen_only() is then
//                             always false). The line counters stay.
// RTUKIT_CORE_IDENTIFICATION  11 report server id, 2B/0E read device
//                             identification (RegisterBank::device_object is
//                             then never called).
// RTUKIT_CORE_MASK_WRITE      16 mask write register.
// RTUKIT_CORE_READ_WRITE      17 read/write multiple registers.
//
// A minimal slave (03/04/06/10 only): every switch 0, as the
// cortex-m4-minimal preset builds it (core/examples/minimal_slave.cpp).
#pragma once

#ifndef RTUKIT_CORE_MASTER
#define RTUKIT_CORE_MASTER 1
#endif
#ifndef RTUKIT_CORE_TCP
#define RTUKIT_CORE_TCP 1
#endif
#ifndef RTUKIT_CORE_COILS
#define RTUKIT_CORE_COILS 1
#endif
#ifndef RTUKIT_CORE_DIAGNOSTICS
#define RTUKIT_CORE_DIAGNOSTICS 1
#endif
#ifndef RTUKIT_CORE_IDENTIFICATION
#define RTUKIT_CORE_IDENTIFICATION 1
#endif
#ifndef RTUKIT_CORE_MASK_WRITE
#define RTUKIT_CORE_MASK_WRITE 1
#endif
#ifndef RTUKIT_CORE_READ_WRITE
#define RTUKIT_CORE_READ_WRITE 1
#endif

#if (RTUKIT_CORE_MASTER != 0 && RTUKIT_CORE_MASTER != 1) ||                                                 \
    (RTUKIT_CORE_TCP != 0 && RTUKIT_CORE_TCP != 1) || (RTUKIT_CORE_COILS != 0 && RTUKIT_CORE_COILS != 1) || \
    (RTUKIT_CORE_DIAGNOSTICS != 0 && RTUKIT_CORE_DIAGNOSTICS != 1) ||                                       \
    (RTUKIT_CORE_IDENTIFICATION != 0 && RTUKIT_CORE_IDENTIFICATION != 1) ||                                 \
    (RTUKIT_CORE_MASK_WRITE != 0 && RTUKIT_CORE_MASK_WRITE != 1) ||                                         \
    (RTUKIT_CORE_READ_WRITE != 0 && RTUKIT_CORE_READ_WRITE != 1)
#error "rtukit core switches (RTUKIT_CORE_*) must be 0 or 1"
#endif

namespace rtukit {

/// The switches as constants, for `if constexpr` in function bodies (the
/// framer's prediction and the request decoder use them; `#if` is kept to
/// whole declarations and definitions there).
inline constexpr bool kHasMaster = RTUKIT_CORE_MASTER;
inline constexpr bool kHasTcp = RTUKIT_CORE_TCP;
inline constexpr bool kHasCoils = RTUKIT_CORE_COILS;
inline constexpr bool kHasDiagnostics = RTUKIT_CORE_DIAGNOSTICS;
inline constexpr bool kHasIdentification = RTUKIT_CORE_IDENTIFICATION;
inline constexpr bool kHasMaskWrite = RTUKIT_CORE_MASK_WRITE;
inline constexpr bool kHasReadWrite = RTUKIT_CORE_READ_WRITE;

/// True when every switch is on: the whole core, as the host build has it.
inline constexpr bool kCoreComplete = RTUKIT_CORE_MASTER && RTUKIT_CORE_TCP && RTUKIT_CORE_COILS &&
                                      RTUKIT_CORE_DIAGNOSTICS && RTUKIT_CORE_IDENTIFICATION &&
                                      RTUKIT_CORE_MASK_WRITE && RTUKIT_CORE_READ_WRITE;

}  // namespace rtukit
