import time
t0 = time.time()
import torch
net = torch.nn.Sequential(torch.nn.Linear(59, 512), torch.nn.ELU(), torch.nn.Linear(512, 256), torch.nn.ELU(),
                          torch.nn.Linear(256, 30)).cuda()
opt = torch.optim.Adam(net.parameters(), lr=1e-3)
obs = torch.randn(4096, 59, device="cuda")
for _ in range(3):
    a, b = torch.nn.functional.softplus(net(obs)).add(1.0).chunk(2, dim=-1)
    dist = torch.distributions.Beta(a, b)
    x = dist.sample().clamp(1e-4, 1 - 1e-4)
    loss = -(dist.log_prob(x).sum(-1).mean() + 0.01 * dist.entropy().sum(-1).mean())
    opt.zero_grad(); loss.backward(); torch.nn.utils.clip_grad_norm_(net.parameters(), 1.0); opt.step()
torch.cuda.synchronize()
print(f"torch PPO step: {time.time() - t0:.1f} s")
