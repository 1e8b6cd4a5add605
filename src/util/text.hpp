#pragma once
// Number parsing/formatting and string helpers: declared in the public isowrench/io.hpp (the CLI
// uses them too); this private name stays for the library's sources.

#include "isowrench/io.hpp"
