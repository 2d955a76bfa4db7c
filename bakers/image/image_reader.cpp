#include "bakers/image/image_reader.h"

#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <stdexcept>

#include "bakers/image/oiio_memory.h"

namespace kiln::image {

TempImageFile::TempImageFile(const std::string& bytes, const std::string& virtual_name, const std::string& who) {
  const std::string suffix = virtual_name.substr(virtual_name.find_last_of('.'));
  std::string pattern = (std::filesystem::temp_directory_path() / ("kiln-image-XXXXXX" + suffix)).string();
  const int fd = ::mkstemps(pattern.data(), static_cast<int>(suffix.size()));
  if (fd < 0) throw std::runtime_error(who + ": cannot make a temporary file to decode it: " + std::strerror(errno));
  path_ = pattern;
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const std::string why = n < 0 ? std::strerror(errno) : "nothing written";
      ::close(fd);
      ::unlink(path_.c_str());
      throw std::runtime_error(who + ": cannot write a temporary file to decode it (" + path_ + "): " + why);
    }
    done += static_cast<size_t>(n);
  }
  ::close(fd);
}

TempImageFile::~TempImageFile() { ::unlink(path_.c_str()); }

std::unique_ptr<OIIO::ImageInput> open_image_reader(const std::string& bytes, const ImageFormat& format,
                                                    OIIO::Filesystem::IOMemReader& proxy,
                                                    std::unique_ptr<TempImageFile>& temp, const std::string& who) {
  const std::string failed = who + ": could not read the header of the " + std::to_string(bytes.size()) + "-byte " +
                             format.name + " image (truncated or corrupt?): ";
  const std::string advice = "; re-export the file and upload it again";
  std::unique_ptr<OIIO::ImageInput> in = detail::create_reader(format.virtual_name);
  if (!in) throw std::runtime_error(failed + OIIO::geterror() + advice);
  OIIO::ImageSpec spec;
  if (!format.from_file && in->supports("ioproxy")) {
    if (!detail::open_on_proxy(*in, format.virtual_name, proxy)) throw std::runtime_error(failed + in->geterror() + advice);
    return in;
  }
  temp = std::make_unique<TempImageFile>(bytes, format.virtual_name, who);
  if (!in->open(temp->path(), spec)) throw std::runtime_error(failed + in->geterror() + advice);
  return in;
}

}  // namespace kiln::image
