#include "common/keys.h"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

namespace ragdoll {
namespace {
namespace fs = std::filesystem;

class CurveTest : public ::testing::Test {
 protected:
  CurveTest() : dir_(fs::temp_directory_path() / ("curve_test_" + std::to_string(getpid()))) {
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  ~CurveTest() override { fs::remove_all(dir_); }
  std::string Write(const std::string& name, const std::string& text) {
    std::ofstream(dir_ / name) << text;
    return (dir_ / name).string();
  }
  // The message of the error loading `path` throws; empty when it loads.
  static std::string LoadError(const std::string& path) {
    try {
      LoadCertificate(path);
    } catch (const std::runtime_error& e) {
      return e.what();
    }
    return "";
  }
  fs::path dir_;
};

TEST_F(CurveTest, CertificatesRoundTripWithASecretOnlyInTheSecretFile) {
  Certificate c = NewCertificate("actor-7", "actor");
  ASSERT_EQ(c.public_key.size(), 40u);
  ASSERT_EQ(c.secret_key.size(), 40u);
  const std::string pub = (dir_ / "actors" / "actor-7.key").string();
  const std::string sec = (dir_ / "actor-7.key_secret").string();
  SaveCertificate(c, pub, sec);
  Certificate p = LoadCertificate(pub), s = LoadCertificate(sec);
  EXPECT_EQ(p.public_key, c.public_key);
  EXPECT_EQ(p.secret_key, "");
  EXPECT_EQ(p.name, "actor-7");
  EXPECT_EQ(p.role, "actor");
  EXPECT_EQ(s.public_key, c.public_key);
  EXPECT_EQ(s.secret_key, c.secret_key);
  struct stat st {};
  ASSERT_EQ(stat(sec.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600u);  // only the owner reads a secret
  std::ifstream in(pub);
  std::string text((std::istreambuf_iterator<char>(in)), {});
  EXPECT_EQ(text.find(c.secret_key), std::string::npos);
}

TEST_F(CurveTest, ReadsCertificatesWrittenByCzmq) {
  // czmq's zcert_save output, verbatim layout (keys from libzmq's test vectors).
  const std::string path = Write("czmq.key_secret",
                                 "#   ****  Generated on 2024-01-01 00:00:00 by CZMQ  ****\n"
                                 "#   ZeroMQ CURVE **Secret** Certificate\n"
                                 "#   DO NOT PROVIDE THIS FILE TO OTHER USERS nor change its "
                                 "permissions.\n\n"
                                 "metadata\n"
                                 "    name = \"server\"\n"
                                 "curve\n"
                                 "    public-key = \"rq:rM>}U?@Lns47E1%kR.o@n%FcmmsL/@{H8]yf7\"\n"
                                 "    secret-key = \"JTKVSB%%)wK0E.X)V>+}o?pNmC{O&4W4b!Ni{Lh6\"\n");
  Certificate c = LoadCertificate(path);
  EXPECT_EQ(c.name, "server");
  EXPECT_EQ(c.public_key, "rq:rM>}U?@Lns47E1%kR.o@n%FcmmsL/@{H8]yf7");
  EXPECT_EQ(c.secret_key, "JTKVSB%%)wK0E.X)V>+}o?pNmC{O&4W4b!Ni{Lh6");
}

TEST_F(CurveTest, BadCertificatesAreRefusedNamingFileAndLine) {
  const Certificate c = NewCertificate("x", "");
  const Certificate other = NewCertificate("y", "");
  auto cert = [](const std::string& pub, const std::string& sec) {
    std::string t = "metadata\n    name = \"x\"\ncurve\n    public-key = \"" + pub + "\"\n";
    if (!sec.empty()) t += "    secret-key = \"" + sec + "\"\n";
    return t;
  };
  EXPECT_EQ(LoadError(Write("good.key", cert(c.public_key, ""))), "");
  EXPECT_EQ(LoadError(Write("good.key_secret", cert(c.public_key, c.secret_key))), "");
  // A key one character short, a character outside Z85, a secret of another pair, no key at all,
  // a line that is not a property, an empty file, a missing file.
  EXPECT_EQ(LoadError(Write("short.key", cert(c.public_key.substr(1), ""))),
            (dir_ / "short.key").string() + ":4: public-key is not a 40-character Z85 key");
  std::string bad = c.public_key;
  bad[5] = '"';
  EXPECT_NE(LoadError(Write("quote.key", cert(bad, ""))).find("quote.key:4:"), std::string::npos);
  bad = c.public_key;
  bad[5] = '~';
  EXPECT_NE(LoadError(Write("tilde.key", cert(bad, ""))).find("not a 40-character Z85 key"),
            std::string::npos);
  EXPECT_EQ(LoadError(Write("mixed.key_secret", cert(c.public_key, other.secret_key))),
            (dir_ / "mixed.key_secret").string() + ":5: secret-key does not belong to public-key");
  EXPECT_NE(
      LoadError(Write("none.key", "metadata\n    name = \"x\"\n")).find("no curve public-key"),
      std::string::npos);
  EXPECT_NE(LoadError(Write("junk.key", "curve\n    public key\n")).find("junk.key:2: expected"),
            std::string::npos);
  EXPECT_NE(LoadError(Write("empty.key", "")).find("no curve public-key"), std::string::npos);
  EXPECT_NE(LoadError((dir_ / "absent.key").string()).find("cannot read"), std::string::npos);
}

TEST_F(CurveTest, RolesFindTheirKeysInTheFolderOrSayWhatIsMissing) {
  auto error = [](const std::string& keys, const std::string& role, const std::string& own) {
    try {
      LoadCurve(keys, role, own);
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_FALSE(LoadCurve("", "actor").enabled());  // no folder: plaintext
  EXPECT_NE(error(dir_.string(), "actor", "").find("broker.key: missing"), std::string::npos);
  const Certificate broker = NewCertificate("broker", "broker");
  SaveCertificate(broker, (dir_ / "broker.key").string(), (dir_ / "broker.key_secret").string());
  EXPECT_NE(error(dir_.string(), "actor", "").find("actor.key_secret: missing"), std::string::npos);
  EXPECT_NE(error(dir_.string(), "actor", "").find("ragdoll keygen"), std::string::npos);
  const Certificate actor = NewCertificate("actor", "actor");
  SaveCertificate(actor, (dir_ / "actors" / "actor.key").string(),
                  (dir_ / "actor.key_secret").string());
  Curve curve = LoadCurve(dir_.string(), "actor");
  EXPECT_TRUE(curve.enabled());
  EXPECT_EQ(curve.server_key, broker.public_key);
  EXPECT_EQ(curve.public_key, actor.public_key);
  EXPECT_EQ(curve.secret_key, actor.secret_key);
  // An explicit certificate wins; a public one cannot serve as a process's own.
  EXPECT_EQ(LoadCurve(dir_.string(), "actor", (dir_ / "broker.key_secret").string()).public_key,
            broker.public_key);
  EXPECT_NE(error(dir_.string(), "actor", (dir_ / "actors" / "actor.key").string())
                .find("holds no secret-key"),
            std::string::npos);
  // The broker's list of actors: every public certificate of the folder.
  SaveCertificate(NewCertificate("b", "actor"), (dir_ / "actors" / "b.key").string(), "");
  std::vector<Certificate> listed = LoadPublicCertificates((dir_ / "actors").string());
  ASSERT_EQ(listed.size(), 2u);
  EXPECT_EQ(listed[0].name, "actor");
  EXPECT_EQ(listed[1].name, "b");
  EXPECT_TRUE(LoadPublicCertificates((dir_ / "nowhere").string()).empty());
}

TEST(LoopbackTest, TellsLoopbackFromNetworkAddresses) {
  for (const char* a : {"127.0.0.1", "127.1.2.3", "localhost", "::1", "[::1]", "lo"}) {
    EXPECT_TRUE(IsLoopback(a)) << a;
  }
  for (const char* a : {"*", "0.0.0.0", "192.168.1.4", "::", "broker", "eth0", ""}) {
    EXPECT_FALSE(IsLoopback(a)) << a;
  }
}

}  // namespace
}  // namespace ragdoll
