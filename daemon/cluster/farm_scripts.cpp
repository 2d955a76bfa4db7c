#include "daemon/cluster/farm_scripts.h"

namespace kiln::cluster::scripts {

namespace {

// Helpers every script shares. A job's state lives in its hash, in the sorted set of its state and in the counts;
// move_state changes the three together.
const char* const kPrelude = R"lua(
local p = ARGV[1]
local function job_key(id) return p .. 'job:' .. id end
local function move_state(id, seq, from, to)
  redis.call('ZREM', p .. 'jobs:' .. from, id)
  redis.call('ZADD', p .. 'jobs:' .. to, seq, id)
  redis.call('HINCRBY', p .. 'counts', from, -1)
  redis.call('HINCRBY', p .. 'counts', to, 1)
  redis.call('HSET', job_key(id), 'state', to)
end
local function unpin(inputs)
  for d in string.gmatch(inputs or '', '[^,]+') do
    if redis.call('HINCRBY', p .. 'pins', d, -1) <= 0 then redis.call('HDEL', p .. 'pins', d) end
  end
end
local function drop_entry(level, entry)
  if level and entry and entry ~= '' then
    local stream = p .. 'q:' .. level
    redis.call('XACK', stream, 'workers', entry)
    redis.call('XDEL', stream, entry)
  end
end
local function publish(id, state, fraction, message)
  local payload = state .. '\n' .. fraction .. '\n\n0\n\n' .. message
  redis.call('HSET', job_key(id), 'progress', payload)
  redis.call('PUBLISH', p .. 'ev:' .. id, payload)
end
-- A blob's last use (retention evicts the least recently used first, never one used within its grace).
local function used(digests, now)
  for d in string.gmatch(digests or '', '[^,]+') do redis.call('ZADD', p .. 'blob_used', 'GT', now, d) end
end
-- queued or running → a final state: counts, pins, its queue entry, the final event. PREFIXfinished scores every
-- finished job by its last use, for the expiry of old records.
local function finish(id, to, now, message)
  local jk = job_key(id)
  local f = redis.call('HMGET', jk, 'seq', 'state', 'inputs', 'priority', 'entry')
  move_state(id, f[1], f[2], to)
  redis.call('HSET', jk, 'finished', now)
  redis.call('ZADD', p .. 'finished', now, id)
  redis.call('HDEL', jk, 'node', 'cancel', 'entry')
  unpin(f[3])
  drop_entry(f[4], f[5])
  publish(id, to, to == 'succeeded' and '1' or '0', message)
end
-- Every succeeded result that refers to the blob leaves the cache and can no longer be fetched.
local function mark_evicted(d, now)
  local count = 0
  for _, id in ipairs(redis.call('SMEMBERS', p .. 'out:' .. d)) do
    local jk = job_key(id)
    if redis.call('HGET', jk, 'state') == 'succeeded' and not redis.call('HGET', jk, 'evicted') then
      redis.call('HSET', jk, 'evicted', now)
      local cache = p .. 'cache:' .. redis.call('HGET', jk, 'spec_key')
      if redis.call('GET', cache) == id then redis.call('DEL', cache) end
      count = count + 1
    end
  end
  return count
end
)lua";

const char* const kInsert = R"lua(
local id, spec_key, priority, idem, inputs, now = ARGV[2], ARGV[6], ARGV[7], ARGV[8], ARGV[9], ARGV[10]
local cache_source = ARGV[11]
if idem ~= '' then
  local existing = redis.call('GET', p .. 'idem:' .. idem)
  if existing then
    if redis.call('HGET', job_key(existing), 'spec_key') == spec_key then return {0, existing} end
    return redis.error_reply('KILN_ALREADY_EXISTS ' .. existing)
  end
end
-- An input the farm's retention removed a moment ago (its tombstone is younger than ARGV[15] s): the service saw
-- the file before the removal, so the job would start without it.
local recent = tonumber(now) - tonumber(ARGV[15])
for d in string.gmatch(inputs, '[^,]+') do
  local evicted = redis.call('ZSCORE', p .. 'evicting', d)
  if evicted and tonumber(evicted) > recent then return redis.error_reply('KILN_EVICTED ' .. d) end
end
-- A cached result evicted since the service looked it up: the job bakes instead.
if cache_source ~= '' then
  local src = redis.call('HMGET', job_key(cache_source), 'state', 'evicted')
  if src[1] ~= 'succeeded' or src[2] then cache_source = '' end
end
local max_queued = tonumber(ARGV[14])
if cache_source == '' and max_queued > 0 then
  local queued = tonumber(redis.call('HGET', p .. 'counts', 'queued') or '0')
  if queued >= max_queued then return {-1, tostring(queued)} end
end
local seq = redis.call('INCR', p .. 'seq')
local jk = job_key(id)
local state = cache_source ~= '' and 'succeeded' or 'queued'
redis.call('HSET', jk, 'seq', seq, 'name', ARGV[3], 'type', ARGV[4], 'spec', ARGV[5], 'spec_key', spec_key,
           'priority', priority, 'state', state, 'submitted', now, 'last_used', now, 'inputs', inputs, 'attempts', 0)
if idem ~= '' then
  redis.call('HSET', jk, 'idem', idem)
  redis.call('SET', p .. 'idem:' .. idem, id)
end
redis.call('ZADD', p .. 'jobs', seq, id)
redis.call('ZADD', p .. 'jobs:' .. state, seq, id)
redis.call('HINCRBY', p .. 'counts', state, 1)
if cache_source ~= '' then
  redis.call('HSET', jk, 'started', now, 'finished', now, 'result', ARGV[12], 'outputs', ARGV[13],
             'cache_source', cache_source, 'progress', 'succeeded\n1\n\n0\n\nanswered from the result cache')
  redis.call('HINCRBY', p .. 'counts', 'cache_hits', 1)
  redis.call('HSET', job_key(cache_source), 'last_used', now)
  redis.call('ZADD', p .. 'finished', now, id)
  redis.call('ZADD', p .. 'finished', 'XX', 'GT', now, cache_source)
  for d in string.gmatch(ARGV[13], '[^,]+') do redis.call('SADD', p .. 'out:' .. d, id) end
  used(ARGV[13], now)
  return {1, id}
end
-- Pinned before the job can be seen in a queue, so retention never removes what it reads.
for d in string.gmatch(inputs, '[^,]+') do redis.call('HINCRBY', p .. 'pins', d, 1) end
used(inputs, now)
local stream = p .. 'q:' .. priority
if redis.call('EXISTS', stream) == 0 then redis.call('XGROUP', 'CREATE', stream, 'workers', '0', 'MKSTREAM') end
redis.call('ZADD', p .. 'q:levels', tonumber(priority), priority)
local entry = redis.call('XADD', stream, '*', 'id', id)
redis.call('HSET', jk, 'entry', entry, 'progress', 'queued\n0\n\n0\n\n')
redis.call('PUBLISH', p .. 'queued', priority)  -- wakes idle workers on every node at once
return {1, id}
)lua";

// Levels from the highest priority down; in each, first an entry whose lease ran out (XPENDING IDLE, then XCLAIM:
// exact, where XAUTOCLAIM would scan at most ten times its COUNT and take every entry it found), else a new one.
// Entries of jobs that finished meanwhile (cancelled while queued) are dropped on the way, at most 64 a call.
const char* const kClaim = R"lua(
local consumer, lease, now, max_crash, node = ARGV[2], ARGV[3], ARGV[4], tonumber(ARGV[5]), ARGV[6]
local function take(level, entry, id, reclaimed)
  local jk = job_key(id)
  local f = redis.call('HMGET', jk, 'state', 'cancel', 'attempts', 'entry', 'seq')
  if (not f[1]) or (f[1] ~= 'queued' and f[1] ~= 'running') or f[4] ~= entry then
    drop_entry(level, entry)  -- finished, or superseded by a newer entry of the same job
    return nil
  end
  if f[2] then
    finish(id, 'cancelled', now, 'cancelled while its node was gone')
    return nil
  end
  local attempts = tonumber(f[3] or '0')
  if reclaimed and max_crash > 0 and attempts >= max_crash then
    local why = 'the kilnd nodes running this job stopped ' .. attempts .. ' times in a row, reaching the ' ..
      'crash-loop limit (max_crash_restarts = ' .. max_crash .. ', set in kilnd.conf or with ' ..
      '--max-crash-restarts; 0 means no limit); it was not started again, in case it is what stops them. ' ..
      'Check the nodes\' logs for the cause, then resubmit it'
    redis.call('HSET', jk, 'error', why)
    finish(id, 'failed', now, why)
    return nil
  end
  if f[1] == 'queued' then move_state(id, f[5], 'queued', 'running') end
  redis.call('HSET', jk, 'node', node, 'started', now, 'attempts', attempts + 1)
  publish(id, 'running', '0', '')
  return {level, entry, id, redis.call('HGETALL', jk)}
end
local budget = 64
for _, level in ipairs(redis.call('ZREVRANGE', p .. 'q:levels', 0, -1)) do
  local stream = p .. 'q:' .. level
  while budget > 0 do
    budget = budget - 1
    local entry, reclaimed
    local expired = redis.call('XPENDING', stream, 'workers', 'IDLE', lease, '-', '+', 1)
    if #expired > 0 then
      entry, reclaimed = expired[1][1], true
      redis.call('XCLAIM', stream, 'workers', consumer, lease, entry, 'JUSTID')
    else
      local r = redis.call('XREADGROUP', 'GROUP', 'workers', consumer, 'COUNT', 1, 'STREAMS', stream, '>')
      if not r then break end
      entry, reclaimed = r[1][2][1][1], false
    end
    local found = redis.call('XRANGE', stream, entry, entry)
    if #found == 0 then
      redis.call('XACK', stream, 'workers', entry)
    else
      local got = take(level, entry, found[1][2][2], reclaimed)
      if got then return got end
    end
  end
  if redis.call('XLEN', stream) == 0 then redis.call('ZREM', p .. 'q:levels', level) end
end
return nil
)lua";

const char* const kRenew = R"lua(
local consumer, stream, entry = ARGV[2], p .. 'q:' .. ARGV[3], ARGV[4]
local r = redis.call('XPENDING', stream, 'workers', entry, entry, 1)
if #r == 0 or r[1][2] ~= consumer then return {0, 0} end
redis.call('XCLAIM', stream, 'workers', consumer, 0, entry, 'JUSTID')
return {1, redis.call('HGET', job_key(ARGV[5]), 'cancel') and 1 or 0}
)lua";

const char* const kCommit = R"lua(
local id, level, entry, outcome, now = ARGV[2], ARGV[3], ARGV[4], ARGV[5], ARGV[6]
local jk = job_key(id)
local f = redis.call('HMGET', jk, 'state', 'spec_key')
if not f[1] then return redis.error_reply('KILN_NOT_FOUND ' .. id) end
if f[1] ~= 'running' and f[1] ~= 'queued' then
  redis.call('HINCRBY', p .. 'counts', 'duplicates', 1)
  drop_entry(level, entry)
  return {0, f[1]}
end
if outcome == 'succeeded' then
  redis.call('HSET', jk, 'result', ARGV[7], 'outputs', ARGV[8], 'last_used', now)
  redis.call('SET', p .. 'cache:' .. f[2], id)
  for d in string.gmatch(ARGV[8], '[^,]+') do redis.call('SADD', p .. 'out:' .. d, id) end
  used(ARGV[8], now)
elseif outcome == 'failed' then
  redis.call('HSET', jk, 'error', ARGV[7])
end
-- This run's entry, when the job's current one is another (it was handed back or reclaimed meanwhile).
if redis.call('HGET', jk, 'entry') ~= entry then drop_entry(level, entry) end
finish(id, outcome, now, outcome == 'failed' and ARGV[7] or '')
return {1, outcome}
)lua";

const char* const kRequeue = R"lua(
local id, level, entry, consumer = ARGV[2], ARGV[3], ARGV[4], ARGV[5]
local jk = job_key(id)
local stream = p .. 'q:' .. level
local pending = redis.call('XPENDING', stream, 'workers', entry, entry, 1)
if #pending == 0 or pending[1][2] ~= consumer or redis.call('HGET', jk, 'state') ~= 'running' then return 0 end
drop_entry(level, entry)
local new_entry = redis.call('XADD', stream, '*', 'id', id)
redis.call('ZADD', p .. 'q:levels', tonumber(level), level)
-- A handed-back run was not a crash: it does not count against the crash-loop limit.
local attempts = tonumber(redis.call('HGET', jk, 'attempts') or '1')
redis.call('HSET', jk, 'entry', new_entry, 'attempts', math.max(attempts - 1, 0))
redis.call('HDEL', jk, 'started', 'node')
move_state(id, redis.call('HGET', jk, 'seq'), 'running', 'queued')
publish(id, 'queued', '0', 'handed back by a node that stopped; it runs again on the next free worker')
redis.call('PUBLISH', p .. 'queued', level)
return 1
)lua";

const char* const kCancel = R"lua(
local id, now = ARGV[2], ARGV[3]
local state = redis.call('HGET', job_key(id), 'state')
if state == 'queued' then
  finish(id, 'cancelled', now, 'cancelled before it ran')
  return 'removed_from_queue'
end
if state == 'running' then
  redis.call('HSET', job_key(id), 'cancel', '1')
  redis.call('PUBLISH', p .. 'cancel', id)
  return 'signalled'
end
return 'unknown'
)lua";

// Every result that refers to a removed or damaged blob leaves the cache and can no longer be fetched.
const char* const kEvictResults = R"lua(
local now, count = ARGV[2], 0
for i = 3, #ARGV do count = count + mark_evicted(ARGV[i], now) end
return count
)lua";

// A use of a job's result (a cache hit, a result read): the job and its outputs are recent again.
const char* const kTouch = R"lua(
local id, now = ARGV[2], ARGV[3]
local jk = job_key(id)
if redis.call('EXISTS', jk) == 0 then return 0 end
redis.call('HSET', jk, 'last_used', now)
redis.call('ZADD', p .. 'finished', 'XX', 'GT', now, id)
used(redis.call('HGET', jk, 'outputs'), now)
return 1
)lua";

// One blob, immediately before its file is removed: only by the holder of the retention lock (renewed here), never
// a pinned blob or one used since the cutoff. A tombstone makes a submit that saw the file before its removal
// refuse it (the insert script); the results that refer to it leave the cache.
const char* const kEvictBlob = R"lua(
local token, now, cutoff, lock_ms, d = ARGV[2], ARGV[3], tonumber(ARGV[4]), ARGV[5], ARGV[6]
if redis.call('GET', p .. 'retention') ~= token then return {-1, 0} end
redis.call('PEXPIRE', p .. 'retention', lock_ms)
if redis.call('HEXISTS', p .. 'pins', d) == 1 then return {0, 0} end
local last = redis.call('ZSCORE', p .. 'blob_used', d)
if last and tonumber(last) > cutoff then return {0, 0} end
redis.call('ZADD', p .. 'evicting', now, d)
redis.call('ZREM', p .. 'blob_used', d)
local n = mark_evicted(d, now)
redis.call('DEL', p .. 'out:' .. d)
return {1, n}
)lua";

// Finished jobs last used before the cutoff, at most ARGV[3] of them: the record and every key that names it.
const char* const kExpireJobs = R"lua(
local cutoff, limit = ARGV[2], tonumber(ARGV[3])
local ids = redis.call('ZRANGEBYSCORE', p .. 'finished', '-inf', cutoff, 'LIMIT', 0, limit)
for _, id in ipairs(ids) do
  local jk = job_key(id)
  local f = redis.call('HMGET', jk, 'state', 'spec_key', 'idem', 'outputs')
  if f[1] then
    if f[3] and redis.call('GET', p .. 'idem:' .. f[3]) == id then redis.call('DEL', p .. 'idem:' .. f[3]) end
    if f[2] and redis.call('GET', p .. 'cache:' .. f[2]) == id then redis.call('DEL', p .. 'cache:' .. f[2]) end
    for d in string.gmatch(f[4] or '', '[^,]+') do redis.call('SREM', p .. 'out:' .. d, id) end
    redis.call('ZREM', p .. 'jobs:' .. f[1], id)
    redis.call('DEL', jk)
  end
  redis.call('ZREM', p .. 'jobs', id)
  redis.call('ZREM', p .. 'finished', id)
end
return #ids
)lua";

}  // namespace

const std::string& evict_results() {
  static const std::string s = std::string(kPrelude) + kEvictResults;
  return s;
}

const std::string& touch() {
  static const std::string s = std::string(kPrelude) + kTouch;
  return s;
}
const std::string& evict_blob() {
  static const std::string s = std::string(kPrelude) + kEvictBlob;
  return s;
}
const std::string& expire_jobs() {
  static const std::string s = std::string(kPrelude) + kExpireJobs;
  return s;
}

const std::string& insert() {
  static const std::string s = std::string(kPrelude) + kInsert;
  return s;
}
const std::string& claim() {
  static const std::string s = std::string(kPrelude) + kClaim;
  return s;
}
const std::string& renew() {
  static const std::string s = std::string(kPrelude) + kRenew;
  return s;
}
const std::string& commit() {
  static const std::string s = std::string(kPrelude) + kCommit;
  return s;
}
const std::string& requeue() {
  static const std::string s = std::string(kPrelude) + kRequeue;
  return s;
}
const std::string& cancel() {
  static const std::string s = std::string(kPrelude) + kCancel;
  return s;
}

}  // namespace kiln::cluster::scripts
