#include "daemon/cluster/farm_node.h"

#include <algorithm>

#include "daemon/cluster/farm_job_hash.h"

namespace kiln::cluster {

namespace {

// How often the subscriber looks for new channels to subscribe to, and the lease keeper's period at most: a cancel
// whose message was missed reaches its bake within this (the "within a second").
constexpr std::chrono::milliseconds kTick{200};
constexpr std::chrono::milliseconds kRenewAtMost{1000};
constexpr std::chrono::milliseconds kRetryAtMost{2000};

// Sleeps, waking early when `stop` is requested.
void pause(std::stop_token stop, std::chrono::milliseconds d) {
  std::mutex mu;
  std::condition_variable_any cv;
  std::unique_lock lock(mu);
  cv.wait_for(lock, stop, d, [] { return false; });
}

FarmQueueOptions queue_options(const FarmConfig& c) {
  FarmQueueOptions o;
  o.prefix = c.prefix;
  o.node = c.node;
  o.lease = c.lease;
  o.max_crash_restarts = c.max_crash_restarts;
  return o;
}

}  // namespace

FarmNode::FarmNode(FarmConfig config)
    : config_(std::move(config)), jobs_(config_.prefix), queue_(queue_options(config_)) {
  options_.address = parse_redis_url(config_.url);
  options_.password = config_.password;
  {
    Connection first = connect();
    (*first).command({"PING"});
  }
  subscriber_ = std::jthread([this](std::stop_token stop) { subscriber_loop(stop); });
  keeper_ = std::jthread([this](std::stop_token stop) { keeper_loop(stop); });
}

FarmNode::~FarmNode() {
  subscriber_.request_stop();
  keeper_.request_stop();
  wake_.notify_all();
}

FarmNode::Connection::~Connection() {
  // A client whose connection broke reconnects at its next command: it goes back to the pool all the same.
  node_.round_trips_ += client_->round_trips() - start_;
  std::lock_guard lock(node_.pool_mu_);
  node_.pool_.push_back(std::move(client_));
}

FarmNode::Connection FarmNode::connect() {
  {
    std::lock_guard lock(pool_mu_);
    if (!pool_.empty()) {
      auto client = std::move(pool_.back());
      pool_.pop_back();
      return Connection(*this, std::move(client));
    }
  }
  return Connection(*this, std::make_unique<RedisClient>(options_));
}

void FarmNode::hold(const Claim& claim) {
  std::lock_guard lock(claims_mu_);
  claims_[claim.job.id] = claim;
  lost_.erase(claim.job.id);
}

std::optional<Claim> FarmNode::claim_of(const std::string& id) const {
  std::lock_guard lock(claims_mu_);
  const auto it = claims_.find(id);
  if (it == claims_.end()) return std::nullopt;
  return it->second;
}

void FarmNode::release(const std::string& id) {
  std::lock_guard lock(claims_mu_);
  claims_.erase(id);
  lost_.erase(id);
}

bool FarmNode::lost(const std::string& id) const {
  std::lock_guard lock(claims_mu_);
  return lost_.count(id) > 0;
}

void FarmNode::watch(const std::string& id) {
  std::lock_guard lock(watch_mu_);
  watched_.insert(id);
}

void FarmNode::reachable() {
  std::lock_guard lock(reach_mu_);
  if (reachable_) return;
  reachable_ = true;
  config_.log("farm " + options_.address.describe(), "Redis answers again; taking work again");
}

void FarmNode::unreachable(const std::string& why) {
  std::lock_guard lock(reach_mu_);
  if (!reachable_) return;
  reachable_ = false;
  config_.log("farm " + options_.address.describe(),
              why + "; this node takes no new work and keeps baking what it runs until Redis answers again");
}

uint64_t FarmNode::wake_ticket() {
  std::lock_guard lock(wake_mu_);
  return wakes_;
}

void FarmNode::wait_for_work(uint64_t ticket, std::chrono::milliseconds timeout, std::stop_token stop) {
  std::unique_lock lock(wake_mu_);
  wake_.wait_for(lock, stop, timeout, [&] { return wakes_ != ticket; });
}

void FarmNode::subscribe_pending(RedisClient& redis, std::set<std::string>& subscribed) {
  std::vector<std::string> wanted{config_.prefix + "cancel", config_.prefix + "queued"};
  {
    std::lock_guard lock(watch_mu_);
    for (const std::string& id : watched_) wanted.push_back(config_.prefix + "ev:" + id);
  }
  std::vector<std::string> command{"SUBSCRIBE"};
  for (const std::string& channel : wanted) {
    if (subscribed.insert(channel).second) command.push_back(channel);
  }
  if (command.size() > 1) redis.send(command);
}

void FarmNode::resync(const std::string& id) {
  // A pooled connection: the subscriber's own allows only (UN)SUBSCRIBE and PING.
  Connection c = connect();
  const std::optional<store::Progress> p = jobs_.latest(*c, id);
  if (p && store::is_terminal(p->state)) {
    mirror_.finish(id, *p);
    std::lock_guard lock(watch_mu_);
    watched_.erase(id);
  } else if (p) {
    mirror_.publish(id, *p);
  }
}

void FarmNode::on_message(RedisClient& redis, const std::string& channel, const std::string& payload) {
  if (channel == config_.prefix + "queued") {
    {
      std::lock_guard lock(wake_mu_);
      ++wakes_;
    }
    wake_.notify_all();
    return;
  }
  if (channel == config_.prefix + "cancel") {
    if (claim_of(payload)) {
      if (auto flag = local_.cancel_flag(payload)) *flag = true;
    }
    return;
  }
  const std::string ev = config_.prefix + "ev:";
  if (channel.rfind(ev, 0) != 0) return;
  const std::string id = channel.substr(ev.size());
  const std::optional<store::Progress> p = decode_progress(payload);
  if (!p) return;
  if (store::is_terminal(p->state)) {
    mirror_.finish(id, *p);
    std::lock_guard lock(watch_mu_);
    watched_.erase(id);
    redis.send({"UNSUBSCRIBE", channel});
  } else {
    mirror_.publish(id, *p);
  }
}

void FarmNode::subscriber_loop(std::stop_token stop) {
  auto backoff = std::chrono::milliseconds(100);
  while (!stop.stop_requested()) {
    std::set<std::string> subscribed;
    try {
      RedisClient redis(options_);
      for (;;) {
        if (stop.stop_requested()) return;
        const uint64_t before = redis.round_trips();
        subscribe_pending(redis, subscribed);
        round_trips_ += redis.round_trips() - before;
        const std::optional<RedisReply> r = redis.receive(kTick);
        if (!r || r->type != RedisReply::Type::array || r->elements.size() < 3) continue;
        const std::string& kind = r->elements[0].str;
        if (kind == "message") on_message(redis, r->elements[1].str, r->elements[2].str);
        // Once subscribed to a job's events, its stored state: an event published before is not missed.
        const std::string ev = config_.prefix + "ev:";
        if (kind == "subscribe" && r->elements[1].str.rfind(ev, 0) == 0) {
          resync(r->elements[1].str.substr(ev.size()));
        }
        backoff = std::chrono::milliseconds(100);
      }
    } catch (const RedisError& e) {
      unreachable(e.what());
    }
    // Events may have been missed meanwhile: every watched job is read again once subscribed again.
    pause(stop, backoff);
    backoff = std::min(backoff * 2, kRetryAtMost);
  }
}

void FarmNode::renew_all(RedisClient& redis) {
  std::vector<Claim> held;
  {
    std::lock_guard lock(claims_mu_);
    for (const auto& [id, c] : claims_) {
      if (!lost_.count(id)) held.push_back(c);
    }
  }
  for (const Claim& c : held) {
    const LeaseState s = queue_.renew(redis, c);
    if (s.held && !s.cancel_requested) continue;
    if (!s.held) {
      std::lock_guard lock(claims_mu_);
      lost_.insert(c.job.id);
      config_.log("job " + c.job.id,
                  "its lease passed to another node (this one was out of reach past the lease); "
                  "stopping this run, the other node's counts");
    }
    if (auto flag = local_.cancel_flag(c.job.id)) *flag = true;
  }
}

void FarmNode::keeper_loop(std::stop_token stop) {
  const auto period = std::min<std::chrono::milliseconds>(config_.lease / 3, kRenewAtMost);
  std::optional<RedisClient> redis;
  while (!stop.stop_requested()) {
    try {
      if (!redis) redis.emplace(options_);
      const uint64_t before = redis->round_trips();
      renew_all(*redis);
      round_trips_ += redis->round_trips() - before;
    } catch (const RedisError& e) {
      unreachable(e.what());
    }
    pause(stop, period);
  }
}

}  // namespace kiln::cluster
