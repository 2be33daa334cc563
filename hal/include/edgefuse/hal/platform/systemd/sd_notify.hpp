// systemd readiness and watchdog (sd_notify) by the documented datagram protocol on
// $NOTIFY_SOCKET, so no libsystemd is needed on the board. Without systemd every call is a no-op.
#pragma once

#include <cstdint>

namespace edgefuse::hal {

//! Sends one notification ("READY=1", "WATCHDOG=1", "STOPPING=1", "STATUS=...").
//! \param state the text
//! \return true if sent, false without $NOTIFY_SOCKET or on error
bool sd_notify_send(const char* state);

//! The watchdog period systemd asks for ($WATCHDOG_USEC for this process), 0 if none.
uint64_t sd_watchdog_usec();

}  // namespace edgefuse::hal
