// Checks on an EXR file's header(s) before OpenEXR reads them: what the header declares must fit in the file, and
// what reading the pixels takes must stay bounded, whatever the header claims.
#pragma once

#include <string>

namespace kiln::image {

// Throws std::runtime_error naming `who` and what is wrong when, in any header of the EXR file `bytes` (which start
// with the EXR magic number):
// - an attribute declares a size that is negative or larger than the bytes left in the file, or OpenEXR would read
//   (and allocate) past them. OpenEXR sizes a string attribute's value from that field before reading it: a 485-byte
//   upload claiming a 1.7 GB "capDate" made the decoder allocate and zero 1.7 GB. The walk follows OpenEXR 3.1's
//   typed readers, which read fixed types and channel lists whatever their size field says (a "chlist" declared 3
//   bytes short hid the next attribute, a 2 GB string, from a walk by the size fields);
// - 256 scanlines of the data window (its width times the channels' bytes), or a row of tiles, take more than
//   256 MiB. OpenEXR allocates its line buffers when the file is opened (up to 256 scanlines a block, for DWAB) and
//   OpenImageIO reads 256 scanlines at a time: a 424-byte upload declaring 2,097,156 x 2 float pixels made them
//   allocate 6.4 GB. That allows 65,536 RGBA float pixels a scanline.
// A header cut short is left to OpenEXR, which reports the truncation without allocating. decode_exr, the texture
// decoder and the environment decoder check every EXR so.
void check_exr_header(const std::string& bytes, const std::string& who);

}  // namespace kiln::image
