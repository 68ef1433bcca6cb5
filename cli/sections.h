// Options-file sections (cli/config.h) that more than one command reads.
#pragma once

#include "cli/config.h"
#include "runtime/registration/registration.h"

namespace drape::cli {

// `registration`: drape register, and drape eval's registration table.
extern const ConfigSection<registration::RegistrationOptions> kRegistrationSection;

}  // namespace drape::cli
