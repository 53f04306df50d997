#pragma once
// What the session's HTTP routes (console/web_console.cpp, console/web_api.cpp) check of a request.
namespace httplib {
struct Request;
}

namespace pvcap::console {

// Whether every parameter (name and value) is well-formed UTF-8 (RFC 3629): a page or a client of the
// API sends nothing else, and other bytes stored in the session's events would make its JSON unwritable.
bool parameters_are_text(const httplib::Request& req);

}  // namespace pvcap::console
