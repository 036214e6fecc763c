#include "world/video_writer.h"

#include <opencv2/imgproc.hpp>

extern "C" {
#include <libavcodec/avcodec.h>
#include <libavformat/avformat.h>
#include <libavutil/log.h>
#include <libavutil/opt.h>
#include <libswscale/swscale.h>
}

namespace vigil {

std::optional<VideoFormat> parse_video_format(std::string_view s) {
  if (s == "mp4") return VideoFormat::kMp4;
  if (s == "avi") return VideoFormat::kAvi;
  return std::nullopt;
}

const char* video_extension(VideoFormat f) { return f == VideoFormat::kMp4 ? ".mp4" : ".avi"; }

// One H.264 stream in an MP4 file: BGR frames converted to yuv420p, encoded by libx264, muxed.
struct VideoFile::H264 {
  AVFormatContext* mux = nullptr;
  AVCodecContext* enc = nullptr;
  AVStream* stream = nullptr;
  AVFrame* frame = nullptr;
  AVPacket* packet = nullptr;
  SwsContext* sws = nullptr;
  int64_t next_pts = 0;
  bool header_written = false;

  ~H264() {
    finish();
    sws_freeContext(sws);
    av_packet_free(&packet);
    av_frame_free(&frame);
    avcodec_free_context(&enc);
    if (mux) {
      if (mux->pb) avio_closep(&mux->pb);
      avformat_free_context(mux);
    }
  }

  // Sends one frame (nullptr: flush) and writes every packet the encoder gives back.
  bool send(const AVFrame* f) {
    if (avcodec_send_frame(enc, f) < 0) return false;
    for (;;) {
      const int r = avcodec_receive_packet(enc, packet);
      if (r == AVERROR(EAGAIN) || r == AVERROR_EOF) return true;
      if (r < 0) return false;
      // Each frame lasts one frame time (without it the file's length ends at the last frame's
      // start, and readers that honour it drop that frame).
      if (packet->duration <= 0) packet->duration = 1;
      av_packet_rescale_ts(packet, enc->time_base, stream->time_base);
      packet->stream_index = stream->index;
      if (av_interleaved_write_frame(mux, packet) < 0) return false;  // takes the packet's data
    }
  }

  // Opens the file; an empty string when done, else what failed.
  std::string open(const std::string& path, double fps, cv::Size size) {
    av_log_set_level(AV_LOG_ERROR);  // x264's statistics on stderr: not for a run's log
    if (avformat_alloc_output_context2(&mux, nullptr, "mp4", path.c_str()) < 0 || !mux) return "cannot make an MP4 muxer";
    const AVCodec* codec = avcodec_find_encoder_by_name("libx264");
    if (!codec) return "FFmpeg here has no libx264 encoder";
    stream = avformat_new_stream(mux, nullptr);
    enc = avcodec_alloc_context3(codec);
    frame = av_frame_alloc();
    packet = av_packet_alloc();
    if (!stream || !enc || !frame || !packet) return "out of memory";
    // The rate as a fraction (15 fps: 1/15 s a frame; 29.97: 1001/30000).
    const AVRational rate = av_d2q(fps, 100000);
    enc->width = size.width;
    enc->height = size.height;
    enc->pix_fmt = AV_PIX_FMT_YUV420P;
    enc->time_base = av_inv_q(rate);
    enc->framerate = rate;
    enc->gop_size = 250;
    if (mux->oformat->flags & AVFMT_GLOBALHEADER) enc->flags |= AV_CODEC_FLAG_GLOBAL_HEADER;
    AVDictionary* options = nullptr;
    av_dict_set(&options, "preset", "veryfast", 0);
    av_dict_set(&options, "crf", "23", 0);
    const int opened = avcodec_open2(enc, codec, &options);
    av_dict_free(&options);
    if (opened < 0) return "libx264 refused the stream's settings";
    if (avcodec_parameters_from_context(stream->codecpar, enc) < 0) return "cannot set the stream's parameters";
    stream->time_base = enc->time_base;
    if (avio_open(&mux->pb, path.c_str(), AVIO_FLAG_WRITE) < 0) return "cannot create the file";
    // No wall-clock time in the file: the same frames give the same bytes.
    av_dict_set(&mux->metadata, "creation_time", nullptr, 0);
    if (avformat_write_header(mux, nullptr) < 0) return "cannot write the MP4 header";
    header_written = true;
    frame->format = enc->pix_fmt;
    frame->width = enc->width;
    frame->height = enc->height;
    if (av_frame_get_buffer(frame, 0) < 0) return "out of memory";
    sws = sws_getContext(size.width, size.height, AV_PIX_FMT_BGR24, size.width, size.height, AV_PIX_FMT_YUV420P,
                         SWS_BILINEAR, nullptr, nullptr, nullptr);
    if (!sws) return "cannot convert BGR to yuv420p";
    return "";
  }

  void write(const cv::Mat& bgr) {
    if (av_frame_make_writable(frame) < 0) return;
    const uint8_t* src[1] = {bgr.data};
    const int stride[1] = {static_cast<int>(bgr.step)};
    sws_scale(sws, src, stride, 0, bgr.rows, frame->data, frame->linesize);
    frame->pts = next_pts++;
    send(frame);
  }

  void finish() {
    if (!header_written) return;
    send(nullptr);
    av_write_trailer(mux);
    header_written = false;
  }
};

namespace {

bool try_open(cv::VideoWriter& w, const std::string& path, int api, int fourcc, double fps, cv::Size size) {
  try {
    return w.open(path, api, fourcc, fps, size);
  } catch (const cv::Exception&) {
    return false;  // the backend is missing or refused: the caller says what
  }
}

}  // namespace

VideoFile::VideoFile() = default;
VideoFile::~VideoFile() { release(); }
VideoFile::VideoFile(VideoFile&&) noexcept = default;
VideoFile& VideoFile::operator=(VideoFile&&) noexcept = default;

void VideoFile::release() {
  if (h264_) {
    h264_->finish();
    h264_.reset();
  }
  writer_.release();
}

bool VideoFile::open(const std::filesystem::path& path, double fps, cv::Size size, VideoFormat format,
                     VideoContent content) {
  release();
  path_ = path;
  frame_size_ = size;
  video_size_ = size;
  why_.clear();
  const std::string p = path.string();
  if (format == VideoFormat::kMp4) {
    video_size_ = cv::Size(size.width + (size.width & 1), size.height + (size.height & 1));
    if (!(fps > 0) || video_size_.width <= 0 || video_size_.height <= 0) {
      why_ = "H.264 needs a positive frame rate and size";
      return false;
    }
    auto h = std::make_unique<H264>();
    const std::string failed = h->open(p, fps, video_size_);
    if (failed.empty()) {
      h264_ = std::move(h);
      return true;
    }
    why_ = "cannot write H.264 in MP4 with FFmpeg here (" + failed + "); --video-format avi writes AVI without it";
    return false;
  }
  if (content == VideoContent::kDrawnView &&
      try_open(writer_, p, cv::CAP_FFMPEG, cv::VideoWriter::fourcc('X', 'V', 'I', 'D'), fps, size))
    return true;
  if (try_open(writer_, p, cv::CAP_OPENCV_MJPEG, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), fps, size)) return true;
  why_ = "OpenCV's MJPEG writer cannot open the file";
  return false;
}

void VideoFile::write(const cv::Mat& frame) {
  if (!is_open() || frame.empty()) return;
  // A frame of another size than the video's is placed top-left on black (H.264 needs even
  // sizes; the AVI writer, the size it was opened with).
  auto padded = [this](const cv::Mat& f) -> const cv::Mat& {
    padded_.create(video_size_, f.type());
    padded_.setTo(cv::Scalar::all(0));
    const cv::Rect r(0, 0, std::min(f.cols, video_size_.width), std::min(f.rows, video_size_.height));
    f(r).copyTo(padded_(r));
    return padded_;
  };
  if (!h264_) {
    writer_.write(frame.size() == video_size_ ? frame : padded(frame));
    return;
  }
  // The encoder takes continuous BGR of the video's size: grey is made colour.
  cv::Mat bgr = frame;
  if (frame.type() == CV_8UC1) cv::cvtColor(frame, bgr, cv::COLOR_GRAY2BGR);
  else if (frame.type() != CV_8UC3) return;  // not a picture
  if (bgr.size() != video_size_ || !bgr.isContinuous()) bgr = padded(bgr);
  h264_->write(bgr);
}

}  // namespace vigil
