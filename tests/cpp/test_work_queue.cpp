// Tests of work_queue.hpp: jobs pushed while the workers run come back in push order on any thread
// count, a job's error comes with it alone, and a queue closed, emptied or dropped early behaves.
#include "quatcurve/work_queue.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <string>
#include <vector>

#include "quatcurve/errors.hpp"

using namespace quatcurve;

namespace {

// A job of some length (so that workers finish out of order): a sum of sines; a negative job fails.
double work(const int& job) {
    if (job < 0) throw InvalidArgument("job " + std::to_string(job));
    double sum = 0.0;
    for (int i = 0; i < 2000 * (job % 7 + 1); ++i) sum += std::sin(job + 1e-3 * i);
    return sum;
}

}  // namespace

TEST(WorkQueue, PushedWhileRunningComeBackInOrderOnAnyThreadCount) {
    for (std::size_t threads : {0u, 1u, 2u, 5u}) {
        for (std::size_t window : {1u, 3u, 100u}) {
            WorkQueue<int, double> queue(work, threads, window);
            std::size_t taken = 0;
            for (int job = 0; job < 40; ++job) {
                queue.push(job);
                EXPECT_EQ(queue.size(), static_cast<std::size_t>(job) + 1);
                if (job % 3 == 2) {  // take some while more are still to come
                    EXPECT_EQ(queue.next(), work(static_cast<int>(taken))) << threads << " threads, job " << taken;
                    ++taken;
                }
            }
            queue.close();
            EXPECT_THROW(queue.push(99), InvalidArgument);
            for (; taken < 40; ++taken) {
                EXPECT_EQ(queue.remaining(), 40 - taken);
                EXPECT_EQ(queue.next(), work(static_cast<int>(taken))) << threads << " threads, job " << taken;
            }
            EXPECT_EQ(queue.remaining(), 0u);
            EXPECT_THROW(queue.next(), InvalidArgument);
        }
    }
}

TEST(WorkQueue, AJobsErrorComesWithItAlone) {
    for (std::size_t threads : {0u, 1u, 3u}) {
        WorkQueue<int, double> queue(work, threads, 2);
        for (int job : {1, 2, -3, 4, 5}) queue.push(job);
        queue.close();
        EXPECT_EQ(queue.next(), work(1));
        EXPECT_EQ(queue.next(), work(2));
        EXPECT_THROW(queue.next(), InvalidArgument);
        EXPECT_EQ(queue.next(), work(4));
        EXPECT_EQ(queue.next(), work(5));
    }
}

TEST(WorkQueue, TakingAheadOfThePushesIsRefused) {
    WorkQueue<int, double> queue(work, 2, 4);
    EXPECT_THROW(queue.next(), InvalidArgument);  // nothing pushed yet
    queue.push(3);
    EXPECT_EQ(queue.next(), work(3));
    EXPECT_THROW(queue.next(), InvalidArgument);  // open, but every job pushed was taken
    EXPECT_THROW((WorkQueue<int, double>(work, 1, 0)), InvalidArgument);
}

TEST(WorkQueue, DroppedEarlyJoinsTheWorkers) {
    // Dropped open or closed, with jobs running, finished and not started: the destructor returns,
    // and no job starts after it (the sanitizer build sees a thread that outlives the queue's data).
    std::atomic<int> started{0};
    auto counted = [&](const int& job) {
        ++started;
        return work(job);
    };
    for (std::size_t threads : {1u, 2u, 4u}) {
        WorkQueue<int, double> queue(counted, threads, 4);
        for (int job = 0; job < 40; ++job) queue.push(job);
        if (threads == 2) queue.close();
        queue.next();
    }
    EXPECT_LT(started.load(), 3 * 40);
    WorkQueue<int, double> idle(work, 3, 1);  // workers waiting for a first job
    EXPECT_EQ(idle.remaining(), 0u);
}
