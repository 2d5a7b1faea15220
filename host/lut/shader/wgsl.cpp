#include "lut/shader/wgsl.hpp"

#include <cctype>
#include <map>
#include <set>
#include <stdexcept>
#include <vector>

namespace ms::lutshader {

namespace {

struct Token {
    enum Kind { ident, number, op, comment, end } kind = end;
    std::string text;
    int line = 0;
};

std::vector<Token> tokenize(const std::string& s) {
    static const char* const two[] = {"<=", ">=", "==", "!=", "&&", "||", "+=", "-=", "*=", "/=", "++", "--"};
    std::vector<Token> out;
    int line = 1;
    std::size_t i = 0;
    while (i < s.size()) {
        const char c = s[i];
        if (c == '\n') {
            ++line, ++i;
            continue;
        }
        if (std::isspace(static_cast<unsigned char>(c))) {
            ++i;
            continue;
        }
        if (c == '/' && i + 1 < s.size() && s[i + 1] == '/') {
            const std::size_t e = s.find('\n', i);
            out.push_back({Token::comment, s.substr(i, (e == std::string::npos ? s.size() : e) - i), line});
            i = e == std::string::npos ? s.size() : e;
            continue;
        }
        if (c == '#') throw std::logic_error("glsl_to_wgsl: preprocessor line at line " + std::to_string(line));
        if (std::isalpha(static_cast<unsigned char>(c)) || c == '_') {
            std::size_t j = i;
            while (j < s.size() && (std::isalnum(static_cast<unsigned char>(s[j])) || s[j] == '_')) ++j;
            out.push_back({Token::ident, s.substr(i, j - i), line});
            i = j;
            continue;
        }
        if (std::isdigit(static_cast<unsigned char>(c)) || (c == '.' && i + 1 < s.size() && std::isdigit(static_cast<unsigned char>(s[i + 1])))) {
            std::size_t j = i;
            while (j < s.size() && (std::isalnum(static_cast<unsigned char>(s[j])) || s[j] == '.' ||
                                    ((s[j] == '-' || s[j] == '+') && (s[j - 1] == 'e' || s[j - 1] == 'E'))))
                ++j;
            out.push_back({Token::number, s.substr(i, j - i), line});
            i = j;
            continue;
        }
        bool matched = false;
        for (const char* t : two)
            if (s.compare(i, 2, t) == 0) {
                out.push_back({Token::op, t, line});
                i += 2;
                matched = true;
                break;
            }
        if (matched) continue;
        if (std::string("+-*/<>=!?:,;(){}[].").find(c) == std::string::npos)
            throw std::logic_error(std::string("glsl_to_wgsl: unexpected '") + c + "' at line " + std::to_string(line));
        out.push_back({Token::op, std::string(1, c), line});
        ++i;
    }
    out.push_back({Token::end, "", line + 1});
    return out;
}

const std::map<std::string, std::string>& wgsl_types() {
    static const std::map<std::string, std::string> types = {
        {"float", "f32"}, {"int", "i32"}, {"uint", "u32"}, {"bool", "bool"}, {"vec2", "vec2<f32>"}, {"vec3", "vec3<f32>"}, {"vec4", "vec4<f32>"}};
    return types;
}

bool is_assignment(const std::string& t) { return t == "=" || t == "+=" || t == "-=" || t == "*=" || t == "/="; }

struct Expr {
    std::string text;
    int precedence = 10;  // 10: primary; binary operators 1 (||) to 6 (* /); 7 unary
    std::string op;       // the binary operator at the top, if any
};

int binary_precedence(const std::string& op) {
    if (op == "||") return 1;
    if (op == "&&") return 2;
    if (op == "==" || op == "!=") return 3;
    if (op == "<" || op == ">" || op == "<=" || op == ">=") return 4;
    if (op == "+" || op == "-") return 5;
    if (op == "*" || op == "/") return 6;
    return 0;
}

class Translator {
public:
    explicit Translator(const std::string& glsl) : tokens_(tokenize(glsl)) {}

    std::string run() {
        int last_line = 0;
        while (peek_any().kind != Token::end) {
            const Token& t = peek_any();
            if (last_line && t.line > last_line + 1) out_ += "\n";  // keep the blank lines between items
            if (t.kind == Token::comment) {
                out_ += t.text + "\n";
                last_line = t.line;
                ++pos_;
                continue;
            }
            function();
            last_line = tokens_[pos_ - 1].line;
        }
        return out_;
    }

private:
    std::vector<Token> tokens_;
    std::size_t pos_ = 0;
    std::string out_;
    std::set<std::string> assigned_;                 // the current function's names assigned after their declaration
    std::set<std::string> parameters_;               // its parameters (immutable in WGSL)
    std::vector<std::string> pending_comments_;      // comments met inside an expression, put after its statement

    [[noreturn]] void fail(const std::string& what) const {
        throw std::logic_error("glsl_to_wgsl: " + what + " at line " + std::to_string(tokens_[pos_].line) + " ('" + tokens_[pos_].text + "')");
    }
    const Token& peek_any() const { return tokens_[pos_]; }
    // The next token that is not a comment (comments inside expressions are kept for later).
    const Token& peek() {
        while (tokens_[pos_].kind == Token::comment) pending_comments_.push_back(tokens_[pos_++].text);
        return tokens_[pos_];
    }
    Token next() {
        peek();
        return tokens_[pos_++];
    }
    bool accept(const std::string& op) {
        if (peek().kind == Token::op && peek().text == op) {
            ++pos_;
            return true;
        }
        return false;
    }
    void expect(const std::string& op) {
        if (!accept(op)) fail("expected '" + op + "'");
    }
    std::string ident() {
        if (peek().kind != Token::ident) fail("expected a name");
        return next().text;
    }
    std::string type_of(const std::string& glsl_type) const {
        const auto it = wgsl_types().find(glsl_type);
        if (it == wgsl_types().end()) fail("unknown type " + glsl_type);
        return it->second;
    }
    bool at_type() { return peek().kind == Token::ident && wgsl_types().count(peek().text); }

    // Names assigned after their declaration in the function body that starts at pos_ ('{').
    void scan_assignments() {
        assigned_.clear();
        int depth = 0;
        std::size_t p = pos_;
        std::vector<std::size_t> code;  // the body's tokens without comments
        for (;; ++p) {
            if (tokens_[p].kind == Token::comment) continue;
            code.push_back(p);
            if (tokens_[p].text == "{") ++depth;
            if (tokens_[p].text == "}" && --depth == 0) break;
            if (tokens_[p].kind == Token::end) fail("unterminated function");
        }
        for (std::size_t k = 0; k + 1 < code.size(); ++k) {
            const Token& t = tokens_[code[k]];
            if (t.kind != Token::ident) continue;
            const Token& before = tokens_[code[k > 0 ? k - 1 : 0]];
            std::size_t after = k + 1;
            while (after + 1 < code.size() && tokens_[code[after]].text == ".") after += 2;  // v.x = ...
            const std::string& a = tokens_[code[after]].text;
            const bool declared_here = k > 0 && (wgsl_types().count(before.text) || before.text == ",");
            if ((is_assignment(a) && !declared_here) || a == "++" || a == "--" || (k > 0 && (before.text == "++" || before.text == "--")))
                assigned_.insert(t.text);
        }
    }

    void function() {
        const std::string ret = ident();
        const std::string name = ident();
        expect("(");
        std::vector<std::string> params;
        parameters_.clear();
        if (!accept(")")) {
            do {
                const std::string type = ident();
                const std::string p = ident();
                parameters_.insert(p);
                if (type == "sampler2D" || type == "sampler3D") {
                    params.push_back(p + ": " + (type == "sampler2D" ? "texture_2d<f32>" : "texture_3d<f32>"));
                    params.push_back(p + "_sampler: sampler");
                } else {
                    params.push_back(p + ": " + type_of(type));
                }
            } while (accept(","));
            expect(")");
        }
        std::string head = "fn " + name + "(";
        for (std::size_t k = 0; k < params.size(); ++k) head += (k ? ", " : "") + params[k];
        head += ")";
        if (ret != "void") head += " -> " + type_of(ret);
        if (peek().text != "{") fail("expected a function body");
        scan_assignments();
        for (const auto& p : parameters_)
            if (assigned_.count(p)) fail("parameter " + p + " is assigned (WGSL parameters are immutable)");
        out_ += head + " ";
        block(0);
        out_ += "\n";
    }

    // A block's statements; the '{' is next. Writes "{\n ... }" (no newline after the brace).
    void block(int indent) {
        expect("{");
        out_ += "{\n";
        while (true) {
            if (peek_any().kind == Token::comment) {
                out_ += pad(indent + 1) + tokens_[pos_++].text + "\n";
                continue;
            }
            if (accept("}")) break;
            statement(indent + 1);
        }
        out_ += pad(indent) + "}";
    }

    static std::string pad(int indent) { return std::string(4 * indent, ' '); }

    // One statement at `indent`, ending with its newline (and a comment on its last line, if any).
    void statement(int indent) {
        if (peek().text == "{") {
            out_ += pad(indent);
            block(indent);
            finish_line();
            return;
        }
        if (peek().kind == Token::ident && peek().text == "if") {
            out_ += pad(indent);
            if_statement(indent);
            return;
        }
        if (peek().kind == Token::ident && peek().text == "for") {
            next();
            expect("(");
            std::string init = "var " + declaration_head();
            expect(";");
            const std::string cond = expression().text;
            expect(";");
            const std::string step = simple_statement_text();
            expect(")");
            out_ += pad(indent) + "for (" + init + "; " + cond + "; " + step + ") ";
            body(indent);
            return;
        }
        if (peek().kind == Token::ident && peek().text == "return") {
            next();
            out_ += pad(indent) + "return";
            if (!accept(";")) {
                out_ += " " + expression().text;
                expect(";");
            }
            out_ += ";";
            finish_line();
            return;
        }
        if (at_type()) {
            const std::string type = type_of(next().text);
            std::vector<std::string> lines;
            do {
                const std::string name = ident();
                expect("=");
                const std::string value = expression().text;
                lines.push_back(std::string(assigned_.count(name) ? "var " : "let ") + name + ": " + type + " = " + value + ";");
            } while (accept(","));
            expect(";");
            for (std::size_t k = 0; k < lines.size(); ++k) {
                out_ += pad(indent) + lines[k];
                if (k + 1 < lines.size()) out_ += "\n";
            }
            finish_line();
            return;
        }
        out_ += pad(indent) + simple_statement_text() + ";";
        expect(";");
        finish_line();
    }

    // `int k = 0` in a for header: "k: i32 = 0".
    std::string declaration_head() {
        if (!at_type()) fail("expected a declaration");
        const std::string type = type_of(next().text);
        const std::string name = ident();
        expect("=");
        return name + ": " + type + " = " + expression().text;
    }

    // An assignment, increment or call, without its ';'.
    std::string simple_statement_text() {
        if (accept("++")) return ident() + "++";
        if (accept("--")) return ident() + "--";
        const Expr target = postfix();
        if (accept("++")) return target.text + "++";
        if (accept("--")) return target.text + "--";
        if (peek().kind == Token::op && is_assignment(peek().text)) {
            const std::string op = next().text;
            return target.text + " " + op + " " + expression().text;
        }
        return target.text;
    }

    // The newline after a statement, with a comment that follows it on the same line.
    void finish_line() {
        const int line = tokens_[pos_ - 1].line;
        if (peek_any().kind == Token::comment && peek_any().line == line) out_ += "  " + tokens_[pos_++].text;
        out_ += "\n";
        for (const auto& c : pending_comments_) out_ += c + "\n";
        pending_comments_.clear();
    }

    // An if, else or for body: braces always (WGSL requires them); no newline after the closing brace.
    void braced_body(int indent) {
        if (peek().text == "{") {
            block(indent);
            return;
        }
        out_ += "{\n";
        statement(indent + 1);
        out_ += pad(indent) + "}";
    }

    void body(int indent) {
        braced_body(indent);
        finish_line();
    }

    void if_statement(int indent) {
        next();  // if
        expect("(");
        const std::string cond = expression().text;
        expect(")");
        out_ += "if (" + cond + ") ";
        // The body, then an else (or else if) on the closing brace's line.
        braced_body(indent);
        if (peek().kind == Token::ident && peek().text == "else") {
            next();
            out_ += " else ";
            if (peek().kind == Token::ident && peek().text == "if") {
                if_statement(indent);
                return;
            }
            braced_body(indent);
        }
        finish_line();
    }

    Expr expression() { return ternary(); }

    Expr ternary() {
        Expr c = binary(1);
        if (!accept("?")) return c;
        const Expr a = ternary();
        expect(":");
        const Expr b = ternary();
        return {"select(" + b.text + ", " + a.text + ", " + c.text + ")", 10, ""};
    }

    Expr binary(int min_precedence) {
        Expr left = unary();
        while (peek().kind == Token::op) {
            const std::string op = peek().text;
            const int p = binary_precedence(op);
            if (p == 0 || p < min_precedence) break;
            next();
            const Expr right = binary(p + 1);
            // WGSL does not mix && and || without parentheses.
            auto operand = [&](const Expr& e) {
                const bool mixed_logic = (op == "||" && e.op == "&&") || (op == "&&" && e.op == "||");
                return mixed_logic ? "(" + e.text + ")" : e.text;
            };
            left = {operand(left) + " " + op + " " + operand(right), p, op};
        }
        return left;
    }

    Expr unary() {
        if (accept("-")) return {"-" + unary().text, 7, ""};
        if (accept("!")) return {"!" + unary().text, 7, ""};
        if (accept("+")) return unary();
        return postfix();
    }

    Expr postfix() {
        Expr e = primary();
        while (true) {
            if (accept(".")) {
                e = {e.text + "." + ident(), 10, ""};
            } else if (accept("[")) {
                e = {e.text + "[" + expression().text + "]", 10, ""};
                expect("]");
            } else {
                return e;
            }
        }
    }

    Expr primary() {
        const Token t = next();
        if (t.kind == Token::number) return {t.text, 10, ""};
        if (t.kind == Token::op && t.text == "(") {
            const Expr inner = expression();
            expect(")");
            return {"(" + inner.text + ")", 10, ""};
        }
        if (t.kind != Token::ident) {
            --pos_;
            fail("expected an expression");
        }
        if (!(peek().kind == Token::op && peek().text == "(")) return {t.text, 10, ""};
        next();  // (
        std::vector<std::string> args;
        if (!accept(")")) {
            do args.push_back(expression().text);
            while (accept(","));
            expect(")");
        }
        std::string name = t.text;
        if (name == "textureLod") {
            if (args.size() != 3) fail("textureLod takes 3 arguments");
            args.insert(args.begin() + 1, args[0] + "_sampler");
            name = "textureSampleLevel";
        } else if (name == "atan" && args.size() == 2) {
            name = "atan2";
        } else if (name == "inversesqrt") {
            name = "inverseSqrt";
        } else if (wgsl_types().count(name)) {
            name = wgsl_types().at(name);
        } else if (name == "mod" || name == "texture" || name == "lerp" || name == "saturate") {
            fail("no WGSL translation for " + name);
        }
        std::string s = name + "(";
        for (std::size_t k = 0; k < args.size(); ++k) s += (k ? ", " : "") + args[k];
        return {s + ")", 10, ""};
    }
};

}  // namespace

std::string glsl_to_wgsl(const std::string& glsl) { return Translator(glsl).run(); }

}  // namespace ms::lutshader
